#pragma once
// A LIDAR node and a reader of one of its topics, in two participants (a topic's QoS may differ
// from the writer's only across participants): the setup the driver-level tests share.
#include <string>

#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/drivers/lidar/lidar_driver.hpp"
#include "status_value.hpp"
#include "wait_bounds.hpp"

namespace sensor_rig::test {

template <class Msg>
struct LidarNodeReader {
  // `suffix`: the topic after /sensors/lidar/<name>/ (points, imu, fix).
  LidarNodeReader(const drivers::LidarConfig& config, const std::string& suffix, int depth)
      : c(config),
        stamps(p),
        topic(sub, "/sensors/lidar/" + c.name + "/" + suffix, qos(depth)),
        reader(sub, topic, qos(depth)),
        driver(c, p, stamps) {}

  static dds::QosSpec qos(int depth) {
    dds::QosSpec q;
    q.depth = depth;
    return q;
  }
  // Starts the node and waits for the reader to match its writer.
  [[nodiscard]] bool start() {
    driver.start();
    return reader.wait_for_writers(1, test::kDiscoveryMs);
  }
  [[nodiscard]] std::string status(const std::string& key) const { return status_value(driver.status(), key); }

  drivers::LidarConfig c;
  dds::Participant p;    // the node's
  dds::Participant sub;  // the reader's
  dds::StampsWriter stamps;
  dds::Topic<Msg> topic;
  dds::Reader<Msg> reader;
  drivers::LidarDriver driver;
};

}  // namespace sensor_rig::test
