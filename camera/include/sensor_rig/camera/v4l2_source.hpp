#pragma once
// V4L2 capture: format negotiation (S_FMT, checked against what the device offers), frame rate
// (S_PARM), controls (exposure, gain), mmap streaming with a bounded ring of buffers. A frame's
// data is the mmap buffer itself; dropping the Frame queues the buffer again (no copy).
// Timestamps: the driver's CLOCK_MONOTONIC buffer time, with CLOCK_REALTIME and CLOCK_MONOTONIC
// sampled together at every dequeue, so the driver maps each frame with a fresh offset. The
// buffer's timestamp type is checked (a stamp not on CLOCK_MONOTONIC is converted or replaced,
// counted and warned), and so is the frame interval the device granted.
#include <linux/videodev2.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sensor_rig/camera/source.hpp"
#include "sensor_rig/camera/v4l2_device.hpp"

namespace sensor_rig::camera {

class V4l2Source final : public FrameSource {
 public:
  V4l2Source(SourceConfig cfg, std::shared_ptr<V4l2Device> dev);
  ~V4l2Source() override;

  void open() override;
  void close() noexcept override;
  [[nodiscard]] bool is_open() const noexcept override { return fd_ >= 0; }
  Capture next(int timeout_ms) override;
  [[nodiscard]] SourceStats stats() const override { return stats_; }
  [[nodiscard]] std::string describe() const override;
  // The exposure the device uses (the config's, else read back), us; 0: unknown.
  [[nodiscard]] double exposure_us() const override { return exposure_us_; }
  // End-of-frame stamp -> exposure start: exposure + readout (ns).
  [[nodiscard]] Nanos eof_offset_ns() const noexcept;
  // The frame rate the device granted (VIDIOC_S_PARM read back; the asked one when it cannot tell),
  // warned at open when it differs from the configured one by more than 0.5 %.
  [[nodiscard]] double granted_frame_rate() const noexcept { return granted_rate_hz_; }
  // The gain written, in dB (V4L2_CID_GAIN read back, converted); < 0: not set.
  [[nodiscard]] double gain_db() const noexcept { return gain_db_; }
  // Buffer timestamps not on CLOCK_MONOTONIC (the flag says UNKNOWN or COPY; old drivers stamped
  // with gettimeofday) and, of all frames, those whose stamp was implausible (after the dequeue,
  // or older than the buffers can hold) and replaced by the dequeue time - exposure - readout.
  struct StampChecks {
    std::uint64_t not_monotonic = 0;  // flag not MONOTONIC: taken as CLOCK_REALTIME where plausible
    std::uint64_t replaced = 0;       // no plausible clock: the dequeue time, back by exposure + readout
  };
  [[nodiscard]] const StampChecks& stamp_checks() const noexcept { return stamp_checks_; }

 private:
  struct Mapped {
    void* addr = nullptr;
    std::size_t length = 0;
  };
  void negotiate_format();
  void set_rate_and_controls();
  void set_gain();
  // eof: in, whether the stamp is the frame's end; out, also true for a stamp replaced by the dequeue.
  Nanos buffer_stamp_mono(const v4l2_buffer& b, Nanos real, Nanos mono, bool& eof) noexcept;
  void start_streaming();
  void requeue(std::uint32_t index) noexcept;
  void count_sequence(std::uint32_t sequence) noexcept;  // a dequeued buffer's sequence: gaps are missing_frames
  void read_frame_syncs() noexcept;    // V4L2_EVENT_FRAME_SYNC events pending: the device's latest sequence
  void count_unseen_tail() noexcept;   // at a close: frames the device began after the last one dequeued
  [[noreturn]] void fail(const std::string& what, int rc);

  SourceConfig cfg_;
  std::shared_ptr<V4l2Device> dev_;
  int fd_ = -1;
  bool streaming_ = false;
  std::uint32_t step_ = 0;
  std::uint32_t image_bytes_ = 0;
  std::vector<Mapped> buffers_;
  SourceStats stats_;
  double exposure_us_ = 0.0;     // set or read back at open; 0: unknown (auto)
  Nanos period_ns_ = 0;          // the frame interval the device granted (S_PARM read back)
  double granted_rate_hz_ = 0.0;
  double gain_db_ = -1.0;
  StampChecks stamp_checks_;
  bool stamp_warned_ = false;    // one warning per open about the buffers' timestamp clock
  std::uint32_t last_sequence_ = 0;
  bool have_sequence_ = false;   // within one open: a stream's sequence restarts at 0 (its first counts the frames lost since STREAMON)
  bool frame_sync_ = false;      // V4L2_EVENT_FRAME_SYNC subscribed (the device sends them; uvcvideo does not)
  std::uint32_t device_sequence_ = 0;  // the latest FRAME_SYNC's frame_sequence, this open
  bool have_device_sequence_ = false;
};

}  // namespace sensor_rig::camera
