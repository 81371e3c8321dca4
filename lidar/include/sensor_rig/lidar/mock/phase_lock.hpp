#pragma once
// Phase lock for synthetic LIDARs, as the real ones do it (Velodyne's "phase lock offset", Ouster's
// phase_lock_offset, Hesai's sync angle): with a PPS- or PTP-disciplined clock, the rotor passes a
// chosen angle at every whole second. Sensors locked to one angle complete their scans together,
// which is how a rig is set up for fusion and the moment the data path carries the most at once.
// Pure: times in, times out.
#include <string>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/mock/synthetic_sensor.hpp"

namespace sensor_rig::lidar::mock {

// Empty when a sensor turning once per `rotation_period_ns` can be locked to the whole second (a
// whole number of turns per second, as 300, 600 and 1200 rpm are), else why not.
std::string phase_lock_error(double rotation_period_ns);

// The earliest timeline start at or after `earliest` that puts the sensor's rotor at `phase_deg`
// (SyntheticSensor::start_rotor_deg's convention: degrees past the scan boundary) on every whole
// second of vehicle time. Throws std::invalid_argument for a phase outside [0, 360) or a period
// phase_lock_error refuses.
Nanos phase_locked_start_ns(const SyntheticSensor& sensor, Nanos earliest, double phase_deg);

// The rotor's angle at vehicle time t for a timeline started at start_ns, [0, 360).
double rotor_deg_at(const SyntheticSensor& sensor, Nanos start_ns, Nanos t);

}  // namespace sensor_rig::lidar::mock
