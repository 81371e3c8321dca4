#pragma once
// Private to AravisSource: reads a camera's exposure time after each frame on a thread of its own
// (a GVCP round trip, never on the capture thread), so that the driver's clock mapping can follow
// an exposure that changes while streaming (issue 27 item 9). On a camera that died mid-read the
// read can take seconds (GVCP retries behind Aravis' heartbeat): abandon() ends the watcher without
// waiting, its thread keeping what it uses (the shared state, a device reference) until it returns.
#include <arv.h>

#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::camera::detail {

struct KnownExposure {
  std::uint64_t seq = 0;  // the frame it was read after (0: none yet)
  Nanos ns = 0;
};

class ExposureWatcher {
 public:
  // `genicam`: the lock every GenICam access of this camera takes (shared with the source).
  ExposureWatcher(ArvDevice* device, std::string feature, std::shared_ptr<std::timed_mutex> genicam);
  ~ExposureWatcher();  // stops and joins (a live camera: at most one read)
  ExposureWatcher(const ExposureWatcher&) = delete;
  ExposureWatcher& operator=(const ExposureWatcher&) = delete;

  void want(std::uint64_t seq);            // frame `seq` just arrived: read its exposure
  [[nodiscard]] KnownExposure known() const;
  void abandon() noexcept;                 // a lost camera: stop without waiting for a read

 private:
  struct Shared;
  std::shared_ptr<Shared> sh_;
  std::thread thread_;
};

}  // namespace sensor_rig::camera::detail
