#pragma once
// GigE Vision (and any Aravis device) as a FrameSource. Open by device id, serial, IP or MAC;
// features applied in a defined order (pixel format, ROI, frame rate, exposure with
// ExposureTime/ExposureTimeAbs tolerance, gain, named features, trigger), GigE packet size and
// delay, the packet socket disabled (it receives nothing from the fake as root, SPEC §8) and a
// fixed socket buffer. Aravis streams into buffers of a bounded pool: the pool memory is the
// published Image.data (no copy). Incomplete frames are counted and never returned. Device loss
// ("control-lost" from the heartbeat thread) turns next() into kDisconnected.
// Aravis types stay in the .cpp: nothing above camera/ includes <arv.h>.
#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "sensor_rig/camera/source.hpp"

namespace sensor_rig::camera {

// Opens the ArvDevice for a device string; returns an owned reference (ArvDevice*) or throws.
// Default: the network (id, IP, MAC, then serial through the device list); camera/mock adds
// in-process fake devices.
using AravisDeviceOpener = std::function<void*(const std::string& device)>;

struct AravisDetails {     // what the device reported after configuration (diagnostics)
  std::string vendor;
  std::string model;
  std::string serial;
  std::string exposure_feature;  // ExposureTime | ExposureTimeAbs | "" (not set)
  int packet_size = 0;
  double frame_rate = 0.0;
};

class AravisSource final : public FrameSource {
 public:
  explicit AravisSource(SourceConfig cfg, AravisDeviceOpener opener = {});
  ~AravisSource() override;

  void open() override;
  void close() noexcept override;
  [[nodiscard]] bool is_open() const noexcept override;
  Capture next(int timeout_ms) override;
  bool trigger() override;
  void mark_lost() noexcept override { control_lost_.store(true); }
  [[nodiscard]] SourceStats stats() const override;
  [[nodiscard]] std::string describe() const override;
  [[nodiscard]] AravisDetails details() const;
  [[nodiscard]] bool control_lost() const noexcept { return control_lost_.load(); }
  // A GenICam feature's value as text (enumerations, strings, numbers); "" when not open/absent.
  [[nodiscard]] std::string feature(const std::string& name) const;

 private:
  struct State;
  void configure();
  void start_stream();
  void fold_stats() noexcept;

  SourceConfig cfg_;
  AravisDeviceOpener opener_;
  mutable std::mutex mutex_;  // camera control (open/close/trigger) from two threads
  std::unique_ptr<State> st_;
  std::atomic<bool> control_lost_{false};
  SourceStats base_;  // totals of streams already closed
  std::atomic<std::uint64_t> timeouts_{0};  // written by the capture thread, read by status()
  std::atomic<std::uint64_t> disconnects_{0};
  std::atomic<std::uint64_t> incomplete_{0};
  std::atomic<std::uint64_t> completed_{0};
  AravisDetails details_;
};

// Aravis' own open by name, falling back to a serial-number match in the device list.
void* open_aravis_network_device(const std::string& device);

}  // namespace sensor_rig::camera
