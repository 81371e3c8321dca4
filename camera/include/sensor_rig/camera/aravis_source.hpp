#pragma once
// GigE Vision (and any Aravis device) as a FrameSource. Open by device id, serial, IP or MAC;
// acquisition stopped first (a live device its last controller left acquiring), then features
// applied in a defined order (pixel format, ROI, frame rate, exposure with
// ExposureTime/ExposureTimeAbs tolerance, gain, named features, trigger), GigE packet size and
// delay, the packet socket disabled (it receives nothing from the fake as root, SPEC §8) and a
// fixed socket buffer. Aravis streams into buffers of a bounded pool: the pool memory is the
// published Image.data (no copy). Incomplete frames are counted and never returned. Device loss
// ("control-lost" from the heartbeat thread) turns next() into kDisconnected.
// Line trigger: FrameStart on TriggerSource trigger_line (one the device offers, else an error
// listing those it does) at TriggerActivation trigger_activation; trigger() sends nothing.
// PTP (cfg.ptp.enable): after the named features PtpEnable (else GevIEEE1588) is set, the status
// (PtpStatus / GevIEEE1588Status, after PtpDataSetLatch / GevIEEE1588DataSetLatch where the device
// has it) read; Faulty, Disabled or Initializing at open is reset (disable, enable). A thread of its own re-reads the status every status_poll_ms (a GVCP round trip: never
// on the capture thread) and resets Faulty/Disabled; while Master/Slave, next() gives
// TimeDomain::kVehicle stamps (TAI -> UTC), otherwise device ticks. A device without the features
// is an error at open.
// Aravis types stay in the .cpp: nothing above camera/ includes <arv.h>.
#include <atomic>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

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
  double exposure_us = 0.0;      // read back after configuration (set or the device's own); 0: no feature
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
  // Sets a GenICam feature now ("name=value" as in SourceConfig::features); throws CameraError.
  void set_feature(const std::string& name, const std::string& value);
  [[nodiscard]] PtpState ptp() const override;
  [[nodiscard]] double exposure_us() const override { return details().exposure_us; }

 private:
  struct State;
  void configure();
  void set_line_trigger();
  void start_stream();
  void fold_stats() noexcept;
  void setup_ptp();                    // under mutex_ + gc_mutex_, at open
  void poll_ptp();                     // under gc_mutex_
  std::string ptp_reset(const std::string& status);
  void publish_ptp(const std::string& status, bool reset, const std::string& error);
  std::string read_ptp_status(std::string& error);
  void stop_ptp_thread() noexcept;

  SourceConfig cfg_;
  AravisDeviceOpener opener_;
  mutable std::mutex mutex_;  // camera control (open/close/trigger) from two threads
  // GenICam access (trigger, features, the PTP poll): taken after mutex_; the PTP thread takes
  // only this one, so stats() never waits for its GVCP round trip.
  mutable std::mutex gc_mutex_;
  std::unique_ptr<State> st_;
  std::atomic<bool> control_lost_{false};
  SourceStats base_;  // totals of streams already closed
  std::atomic<std::uint64_t> timeouts_{0};  // written by the capture thread, read by status()
  std::atomic<std::uint64_t> disconnects_{0};
  std::atomic<std::uint64_t> incomplete_{0};
  std::atomic<std::uint64_t> incomplete_timeout_{0};  // by the buffer's status: where the frame went
  std::atomic<std::uint64_t> incomplete_missing_{0};
  std::atomic<std::uint64_t> incomplete_other_{0};
  std::atomic<std::uint64_t> completed_{0};
  AravisDetails details_;
  // PTP: the state (under ptp_mutex_), the lock flag next() reads, the status thread.
  mutable std::mutex ptp_mutex_;
  PtpState ptp_;
  std::string ptp_status_feature_;
  std::string ptp_latch_feature_;  // PtpDataSetLatch / GevIEEE1588DataSetLatch where offered, run before each read
  std::atomic<bool> ptp_locked_{false};
  std::thread ptp_thread_;
  std::condition_variable ptp_cv_;
  bool ptp_stop_ = false;  // under ptp_mutex_
};

// Aravis' own open by name, falling back to a serial-number match in the device list.
void* open_aravis_network_device(const std::string& device);

}  // namespace sensor_rig::camera
