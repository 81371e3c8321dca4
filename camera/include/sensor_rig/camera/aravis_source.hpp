#pragma once
// GigE Vision (and any Aravis device) as a FrameSource. Open by device id, serial, IP or MAC (an IP
// is probed with one GVCP read outside every lock, then opened by address without discovery);
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

// Aravis' handle types, declared as <arv.h> does (its headers stay out of this one).
struct _ArvCamera;
struct _ArvDevice;
struct _ArvStream;

namespace sensor_rig::camera {
namespace detail {
class ExposureWatcher;
}

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
  // The exposure read back after configuration, or the latest one the status thread read.
  [[nodiscard]] double exposure_us() const override;

 private:
  struct State;
  void configure(State& st, AravisDetails& details);
  // The camera's vendor/model/serial, held while open: a second source on the same camera (another
  // address or its serial) is refused with a CameraError (issue 27 item 13).
  void claim_identity(const AravisDetails& details);
  void release_identity() noexcept;
  void set_line_trigger(_ArvCamera* cam);
  void start_stream(State& st);
  void fold_stats() noexcept;
  // The capture thread's. complete: the buffer's status is SUCCESS (its id is its own; see the .cpp).
  void count_missing_frames(std::uint64_t id, Nanos device_ns, Nanos mono_ns, bool complete) noexcept;
  void count_undelivered(_ArvStream* stream) noexcept;  // close(): frames the stream holds, never returned
  void setup_ptp(_ArvDevice* dev);  // at open, before the state is installed (no lock)
  void poll_ptp();                          // under gc_mutex_
  std::string ptp_reset(_ArvDevice* dev, const std::string& status);
  void publish_ptp(const std::string& status, bool reset, const std::string& error);
  std::string read_ptp_status(_ArvDevice* dev, std::string& error);
  void stop_ptp_thread() noexcept;
  void status_loop();  // the PTP status thread

  SourceConfig cfg_;
  AravisDeviceOpener opener_;
  bool network_ = false;  // the default opener: an address is probed (GVCP) before the open lock
  // Camera control (open/close/trigger) from two threads. Timed: trigger() waits for either lock
  // at most kTriggerLockWaitMs (see trigger()).
  mutable std::timed_mutex mutex_;
  // GenICam access (trigger, features, the PTP poll, the exposure read): taken after mutex_; the
  // PTP thread and the exposure watcher take only this one, so stats() never waits for their GVCP
  // round trips.
  std::shared_ptr<std::timed_mutex> gc_mutex_ = std::make_shared<std::timed_mutex>();  // shared with the exposure watcher
  std::atomic<std::uint64_t> trigger_lock_busy_{0};  // triggers refused: a GenICam access held the camera
  // The stream socket's receive buffer as granted, and what one frame needs (issue 27 item 4).
  std::atomic<std::int64_t> socket_granted_{0};
  std::atomic<std::int64_t> socket_needed_{0};
  std::atomic<bool> socket_warned_{false};  // the WARN once per source, not per reopen
  std::unique_ptr<State> st_;
  std::atomic<bool> control_lost_{false};
  std::atomic<bool> streaming_{false};
  std::atomic<bool> open_{false};       // is_open(): from open() to close()  // open and streaming: trigger() may take the locks
  SourceStats base_;  // totals of streams already closed
  std::atomic<std::uint64_t> timeouts_{0};  // written by the capture thread, read by status()
  std::atomic<std::uint64_t> disconnects_{0};
  std::atomic<std::uint64_t> incomplete_{0};
  std::atomic<std::uint64_t> incomplete_timeout_{0};  // by the buffer's status: where the frame went
  std::atomic<std::uint64_t> incomplete_missing_{0};
  std::atomic<std::uint64_t> incomplete_other_{0};
  std::atomic<std::uint64_t> completed_{0};
  std::atomic<const char*> payload_{""};  // the GVSP payload of the last frame returned
  std::atomic<std::uint64_t> missing_frames_{0};  // block-id gaps (count_missing_frames)
  // The capture thread's (open/close too): the last frame's id (0: none), device time and arrival
  // (CLOCK_MONOTONIC), kept across a close and an open; reopened_: no frame since the last open.
  std::uint64_t last_frame_id_ = 0;
  Nanos last_frame_device_ns_ = 0;
  Nanos last_frame_mono_ns_ = 0;
  bool reopened_ = false;
  // Frames counted lost since the last frame of known id whose own id Aravis did not give (their
  // leader was lost): the next id step covers them, so it counts only the frames beyond them.
  std::uint64_t unknown_id_frames_ = 0;
  AravisDetails details_;
  std::string claimed_;  // the identity claim_identity() holds; "" when none (open()/close() thread)
  // PTP: the state (under ptp_mutex_), the lock flag next() reads, the status thread.
  mutable std::mutex ptp_mutex_;
  PtpState ptp_;
  std::string ptp_status_feature_;
  std::string ptp_latch_feature_;  // PtpDataSetLatch / GevIEEE1588DataSetLatch where offered, run before each read
  std::atomic<bool> ptp_locked_{false};
  std::thread ptp_thread_;
  std::condition_variable ptp_cv_;
  bool ptp_stop_ = false;  // under ptp_mutex_
  std::string exposure_read_feature_;  // ExposureTime | ExposureTimeAbs as read back at open; "": none
  std::unique_ptr<detail::ExposureWatcher> exposure_;  // reads each frame's exposure (capture thread's)
  std::atomic<Nanos> last_exposure_ns_{0};              // the latest it read
};

// The network's device: an IPv4 address is probed (one GVCP READREG, 3 x 100 ms) and opened by
// address (no discovery; a camera that does not answer throws after the probe); any other name by
// Aravis' own open, falling back to a serial-number match in the device list.
void* open_aravis_network_device(const std::string& device);

}  // namespace sensor_rig::camera
