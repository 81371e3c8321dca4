#pragma once
// The LIDAR tests' FaultySensor factory (shared by tests/lidar/scan and tests/lidar/synthetic): a
// synthetic sensor of the options `base` in the standard scene, made again as each SensorSetup
// says (where its timeline starts, its rpm, rotor angle and boot count).
#include "sensor_rig/lidar/mock/scene.hpp"
#include "sensor_rig/lidar/mock/sensor_faults.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"

namespace sensor_rig::lidar::test {

inline mock::SensorFactory synthetic_sensor_factory(const mock::SyntheticOptions& base) {
  return [base](const mock::SensorSetup& s) {
    mock::SyntheticOptions o = base;
    o.start_ns = s.start_ns;
    o.rpm = s.rpm;
    o.start_rotor_deg = s.start_rotor_deg;
    o.boot = s.boot;
    return mock::make_synthetic_sensor(o, mock::Scene::standard());
  };
}

}  // namespace sensor_rig::lidar::test
