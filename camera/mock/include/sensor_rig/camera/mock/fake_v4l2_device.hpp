#pragma once
// A fake V4L2 capture device behind the V4l2Device interface: the real V4l2Source drives it
// (QUERYCAP, ENUM_FMT, S_FMT with size adjustment as drivers do, S_PARM, controls, REQBUFS, mmap,
// QBUF/DQBUF, STREAMON/OFF, poll). Frames come at the negotiated rate, stamped with
// CLOCK_MONOTONIC at exposure start (V4L2_BUF_FLAG_TSTAMP_SRC_SOE). Faults, thread-safe, taking
// effect at the next frame: stall (no frames), disconnect (ENODEV until reconnect), short buffers.
// Under a campaign (FakeV4l2Options::chaos) it takes the plan's v4l2.* faults by time and writes its
// truth record: a unit and a part line per frame slot, a fault line each. Unit = the stream's
// ordinal (its STREAMON, from 0) x 2^32 + the V4L2 sequence, which restarts at 0 with each stream.
// The lines of a call's slots are on disk when it returns: before a frame can be dequeued, and a
// disconnect's not_sent slots once the device is back (a killed driver takes no line with it).
#include <linux/videodev2.h>

#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "sensor_rig/camera/mock/camera_chaos.hpp"
#include "sensor_rig/camera/v4l2_device.hpp"
#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::camera::mock {

struct FakeV4l2Format {
  std::uint32_t fourcc = 0;
  std::uint32_t width = 0;
  std::uint32_t height = 0;
};

struct FakeV4l2Options {
  std::string path = "/dev/video0";
  std::vector<FakeV4l2Format> formats;  // empty: YUYV, GREY, RGGB, RGB3 at 640x480, 1280x720, 1920x1200
  double max_rate_hz = 60.0;
  // The rates it offers, as UVC devices do (S_PARM grants the nearest); empty: any up to max_rate_hz.
  std::vector<double> frame_rates;
  std::uint32_t max_buffers = 8;
  // The buffers' timestamp type flag (V4L2_BUF_FLAG_TIMESTAMP_*): MONOTONIC as drivers since 3.9;
  // UNKNOWN with realtime_stamps as older ones (gettimeofday).
  std::uint32_t timestamp_type = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC;
  bool realtime_stamps = false;  // buffer timestamps on CLOCK_REALTIME instead of CLOCK_MONOTONIC
  // V4L2_CID_GAIN's range (VIDIOC_QUERYCTRL) in the device's own units.
  std::int32_t gain_min = 0, gain_max = 480, gain_step = 1, gain_default = 0;
  // V4L2_EVENT_FRAME_SYNC (VIDIOC_SUBSCRIBE_EVENT / DQEVENT): an event at every frame slot's start,
  // made or dropped, carrying its sequence, as CSI receivers' drivers send; the last few kept (the
  // kernel drops a subscription's oldest). uvcvideo sends none: false, and SUBSCRIBE fails (EINVAL).
  bool frame_sync_events = true;
  ChaosArgs chaos;  // v4l2.stamp_mode, v4l2.sequence_gap, v4l2.disconnect of chaos.device; its truth
};

struct FakeV4l2Counters {
  std::uint64_t frames = 0;         // frames filled
  std::uint64_t dropped = 0;        // frames due while no buffer was queued
  std::uint64_t frame_syncs = 0;    // V4L2_EVENT_FRAME_SYNC events queued (subscribed, one per slot)
  std::uint64_t opens = 0;
  std::uint32_t exposure_100us = 0;  // last V4L2_CID_EXPOSURE_ABSOLUTE
  std::int32_t gain = -1;           // last V4L2_CID_GAIN, raw
  double rate_hz = 0.0;              // negotiated
};

class FakeV4l2Device final : public V4l2Device {
 public:
  explicit FakeV4l2Device(FakeV4l2Options o = {});  // throws std::runtime_error (plan, truth file)
  ~FakeV4l2Device() override = default;

  void stall(bool on);
  void disconnect();
  void reconnect();
  void short_buffers(std::uint32_t every_n);  // every n-th frame carries half an image; 0: off
  [[nodiscard]] FakeV4l2Counters counters() const;

  int open(const std::string& path) override;
  int close(int fd) override;
  int ioctl(int fd, unsigned long request, void* arg) override;
  void* mmap(std::size_t length, int fd, off_t offset) override;
  int munmap(void* addr, std::size_t length) override;
  int poll(int fd, int timeout_ms) override;

 private:
  struct Buffer {
    std::vector<std::uint8_t> mem;
    bool queued = false;
    bool filled = false;
    std::uint32_t bytesused = 0;
    std::uint32_t sequence = 0;
    Nanos stamp_mono = 0;
    Nanos mono_to_stamp_clock = 0;   // realtime_stamps: CLOCK_REALTIME - CLOCK_MONOTONIC when filled
    std::uint32_t stamp_source = 0;  // V4L2_BUF_FLAG_TSTAMP_SRC_SOE or _EOF
    // Its frame's truth, written when the frame leaves the driver: dequeued (sent), discarded by the
    // consumer's STREAMOFF or close (sent: the device delivered it), or gone with the device at a
    // disconnect (dropped: vb2's queue error answers DQBUF with EIO before its done list, so a frame
    // done a moment before the unplug is lost where no V4L2 call tells of it).
    struct Truth {
      bool pending = false;
      std::uint32_t seq = 0;
      Nanos acq_ns = 0, dev_ns = 0, done_ns = 0;  // vehicle time, the device's stamp, when it was filled
    } truth;
  };
  int ioctl_locked(unsigned long request, void* arg);
  bool fill_one(Nanos due);  // with mutex_ held
  void make_slot_locked(Nanos due);
  void frame_sync_locked(std::uint32_t seq);  // with mutex_ held: a subscribed fd's event for this slot
  // With mutex_ held: begins and ends the plan's faults at this instant (disconnect, its fault lines).
  void apply_faults_locked();
  // With mutex_ held: the device returns at `until` (CLOCK_MONOTONIC); its stream is gone.
  void end_disconnect_locked(Nanos until);
  [[nodiscard]] bool gone() const noexcept { return disconnected_ || fault_disconnected_; }
  // With mutex_ held: one frame slot's truth (unit = its sequence).
  void record(std::uint32_t seq, Nanos acq_mono, Nanos dev_mono, truth::Fate fate, std::uint64_t fault);
  [[nodiscard]] Buffer::Truth frame_truth(std::uint32_t seq, Nanos acq_mono, Nanos dev_mono) const;
  void write_truth(Buffer::Truth& t, truth::Fate fate, std::uint64_t fault);  // once: clears `pending`
  // With mutex_ held: the filled buffers the consumer will never dequeue, with this fate (dropped:
  // the device went with them, and they are no longer filled).
  void settle_filled_locked(truth::Fate fate, std::uint64_t fault);
  // With mutex_ held: the lines record() wrote since the last call, on disk.
  void flush_truth_locked();
  // at_s >= 0: when it really began (plan seconds), where that is not its planned time.
  void fault_line(const faults::FaultEvent& e, std::int64_t unit, const std::string& detail, double at_s = -1.0);
  [[nodiscard]] std::int64_t unit_of(std::uint32_t seq) const noexcept;  // the truth's unit of this stream's seq

  FakeV4l2Options opt_;
  mutable std::mutex mutex_;
  int fd_ = -1;
  int next_fd_ = 1000;
  bool disconnected_ = false;
  bool stalled_ = false;
  std::uint32_t short_every_ = 0;
  FakeV4l2Format fmt_;
  std::uint32_t bytesperline_ = 0;
  std::uint32_t sizeimage_ = 0;
  double rate_hz_ = 30.0;
  bool streaming_ = false;
  Nanos next_due_ = 0;
  std::uint32_t sequence_ = 0;  // the V4L2 sequence: 0 at each STREAMON
  std::uint64_t streams_ = 0;   // STREAMONs so far: the truth unit's high 32 bits (its ordinal)
  std::vector<Buffer> buffers_;
  std::deque<std::uint32_t> queue_;  // queued buffers in QBUF order (filled FIFO, as drivers do)
  bool sync_subscribed_ = false;     // V4L2_EVENT_FRAME_SYNC subscribed on the open fd
  std::deque<std::uint32_t> sync_events_;  // their frame_sequence, oldest first
  std::uint32_t event_count_ = 0;    // v4l2_event.sequence
  FakeV4l2Counters counters_;
  // Campaign (empty without one).
  CameraSchedule schedule_;
  std::unique_ptr<CameraTruth> truth_;
  bool truth_unflushed_ = false;      // record() wrote lines still in the writer's buffer
  bool fault_disconnected_ = false;
  Nanos disconnected_at_ = 0;         // CLOCK_MONOTONIC
  std::uint64_t disconnect_fault_ = 0;
  double disconnect_until_s_ = 0;     // plan time: the end of the latest disconnect of this absence
  std::uint32_t gap_left_ = 0;        // slots a sequence gap still skips
  std::uint64_t gap_fault_ = 0;
  std::set<std::uint64_t> gaps_done_;
  std::set<std::uint64_t> disconnects_seen_;  // v4l2.disconnect events with their fault line written
};

}  // namespace sensor_rig::camera::mock
