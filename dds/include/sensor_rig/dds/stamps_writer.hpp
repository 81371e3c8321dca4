#pragma once
// The shared writer of per-sample source stamps (rt/rig/stamps); thread-safe (Cyclone writers are).
#include <cstdint>
#include <map>
#include <mutex>
#include <string>

#include "sensor_rig/dds/types.hpp"

namespace sensor_rig::dds {

inline constexpr const char* kStampsTopic = "/rig/stamps";

struct SampleStamps {
  Nanos acquisition_ns = 0;
  Nanos first_rx_ns = 0;
  Nanos last_rx_ns = 0;
  Nanos ready_ns = 0;
  Nanos publish_ns = 0;
  Nanos written_ns = 0;
  std::uint32_t packets = 0;
  std::uint32_t dropped = 0;
  std::uint32_t size_bytes = 0;
  std::uint32_t missing_packets = 0;  // packets the sample should have had and did not (LIDAR scans)
  Nanos ecu_status_ns = 0;  // dbw commands: the first ECU status frame received after written_ns; 0 = none
};

class StampsWriter {
 public:
  explicit StampsWriter(const dds::Participant& p);
  // Numbers each announcement of `topic` (SourceStamps.published: 1, 2, ... per topic in this
  // writer), so that a reader that lost some, and their samples, counts them exactly where `seq` is
  // a device's frame id (cameras). One thread per topic writes, as every driver does.
  void write(const std::string& topic, const msg::Time& stamp, const char* frame_id, std::uint64_t seq,
             const SampleStamps& s);
  // True once n readers matched (or false after timeout_ms): the topic is volatile, so a stamp
  // written before its reader matched is not delivered to it.
  bool wait_for_readers(std::uint32_t n, int timeout_ms) const { return writer_.wait_for_readers(n, timeout_ms); }

 private:
  dds::Topic<msg::SourceStamps> topic_;
  dds::Writer<msg::SourceStamps> writer_;
  std::mutex mutex_;  // the drivers of a process share one writer
  std::map<std::string, std::uint64_t, std::less<>> published_;
};

// QoS of the stamps topic: reliable, keep-last 64 (many topics feed one monitor).
dds::QosSpec stamps_qos();

}  // namespace sensor_rig::dds
