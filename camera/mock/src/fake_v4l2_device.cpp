#include "sensor_rig/camera/mock/fake_v4l2_device.hpp"

#include <linux/videodev2.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

#include "sensor_rig/camera/pixel_format.hpp"

namespace sensor_rig::camera::mock {
namespace {

constexpr off_t kPage = 4096;

void sleep_ns(Nanos ns) {
  if (ns <= 0) return;
  timespec ts{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
  ::nanosleep(&ts, nullptr);
}

// The fake's model of a frame under v4l2.stamp_mode eof: the buffer is stamped (and ready) when its
// last row is read out, exposure + readout after the exposure started; a rolling shutter reads out
// over about half a frame period at these rates. Exposure unset (auto): 10 ms.
constexpr Nanos kDefaultExposureNs = 10'000'000;
constexpr const char* kClock =
    "CLOCK_MONOTONIC ns: the V4L2 buffer timestamp (start of exposure; under v4l2.stamp_mode eof the end of "
    "the frame: exposure start + exposure + half a frame period of readout)";

std::uint32_t bytes_pp(std::uint32_t fourcc_code) {
  const auto f = from_v4l2(fourcc_code);
  return f ? std::max<std::uint32_t>(1, bytes_per_pixel(*f)) : 1;
}

}  // namespace

FakeV4l2Device::FakeV4l2Device(FakeV4l2Options o) : opt_(std::move(o)), schedule_(opt_.chaos.plan, opt_.chaos.device) {
  if (!opt_.chaos.truth.empty())
    truth_ = std::make_unique<CameraTruth>(opt_.chaos.truth, opt_.chaos.device, "v4l2", "sensor-rig fake V4L2 device", kClock);
  if (opt_.formats.empty())
    for (const auto code : {fourcc('Y', 'U', 'Y', 'V'), fourcc('G', 'R', 'E', 'Y'), fourcc('R', 'G', 'G', 'B'), fourcc('R', 'G', 'B', '3')})
      for (const auto& [w, h] : {std::pair{640u, 480u}, std::pair{1280u, 720u}, std::pair{1920u, 1200u}})
        opt_.formats.push_back({code, w, h});
  fmt_ = opt_.formats.front();
  bytesperline_ = fmt_.width * bytes_pp(fmt_.fourcc);
  sizeimage_ = bytesperline_ * fmt_.height;
}

void FakeV4l2Device::stall(bool on) {
  std::lock_guard lock(mutex_);
  stalled_ = on;
  if (!on) next_due_ = monotonic_now_ns();
}
void FakeV4l2Device::disconnect() {
  std::lock_guard lock(mutex_);
  disconnected_ = true;
  settle_filled_locked(truth::Fate::kDropped, 0);
}
void FakeV4l2Device::reconnect() {
  std::lock_guard lock(mutex_);
  disconnected_ = false;
}
void FakeV4l2Device::short_buffers(std::uint32_t every_n) {
  std::lock_guard lock(mutex_);
  short_every_ = every_n;
}
FakeV4l2Counters FakeV4l2Device::counters() const {
  std::lock_guard lock(mutex_);
  auto c = counters_;
  c.rate_hz = rate_hz_;
  return c;
}

int FakeV4l2Device::open(const std::string& path) {
  std::lock_guard lock(mutex_);
  if (path != opt_.path) return -ENOENT;
  apply_faults_locked();
  if (gone()) return -ENODEV;
  if (fd_ >= 0) return -EBUSY;
  fd_ = next_fd_++;
  ++counters_.opens;
  return fd_;
}

int FakeV4l2Device::close(int fd) {
  std::lock_guard lock(mutex_);
  if (fd != fd_) return -EBADF;
  fd_ = -1;
  streaming_ = false;
  settle_filled_locked(truth::Fate::kSent, 0);  // delivered: the consumer let them go
  buffers_.clear();
  queue_.clear();
  sync_subscribed_ = false;  // a subscription is the file handle's
  sync_events_.clear();
  return 0;
}

void* FakeV4l2Device::mmap(std::size_t length, int fd, off_t offset) {
  std::lock_guard lock(mutex_);
  const auto index = static_cast<std::size_t>(offset / kPage);
  if (fd != fd_ || gone() || offset % kPage != 0 || index >= buffers_.size() || length > buffers_[index].mem.size())
    return nullptr;
  return buffers_[index].mem.data();
}

int FakeV4l2Device::munmap(void* /*addr*/, std::size_t /*length*/) { return 0; }

int FakeV4l2Device::ioctl(int fd, unsigned long request, void* arg) {
  std::lock_guard lock(mutex_);
  if (fd != fd_) return -EBADF;
  apply_faults_locked();
  if (gone()) return -ENODEV;
  return ioctl_locked(request, arg);
}

int FakeV4l2Device::ioctl_locked(unsigned long request, void* arg) {
  switch (request) {
    case VIDIOC_QUERYCAP: {
      auto* c = static_cast<v4l2_capability*>(arg);
      *c = {};
      constexpr char kDriver[] = "sensor-rig-fake";
      constexpr char kCard[] = "fake v4l2 camera";
      static_assert(sizeof kDriver <= sizeof c->driver && sizeof kCard <= sizeof c->card);
      std::memcpy(c->driver, kDriver, sizeof kDriver);
      std::memcpy(c->card, kCard, sizeof kCard);
      c->capabilities = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING | V4L2_CAP_DEVICE_CAPS;
      c->device_caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
      return 0;
    }
    case VIDIOC_ENUM_FMT: {
      auto* d = static_cast<v4l2_fmtdesc*>(arg);
      std::vector<std::uint32_t> codes;
      for (const auto& f : opt_.formats)
        if (std::find(codes.begin(), codes.end(), f.fourcc) == codes.end()) codes.push_back(f.fourcc);
      if (d->index >= codes.size()) return -EINVAL;
      d->pixelformat = codes[d->index];
      return 0;
    }
    case VIDIOC_S_FMT:
    case VIDIOC_G_FMT: {
      auto* f = static_cast<v4l2_format*>(arg);
      if (f->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      if (request == VIDIOC_S_FMT) {
        if (streaming_) return -EBUSY;
        // As drivers do: the nearest size of the wanted fourcc (or of the first format).
        const FakeV4l2Format* best = nullptr;
        std::int64_t best_d = 0;
        for (const auto& c : opt_.formats) {
          if (c.fourcc != f->fmt.pix.pixelformat) continue;
          const std::int64_t d = std::llabs(static_cast<std::int64_t>(c.width) - f->fmt.pix.width) +
                                 std::llabs(static_cast<std::int64_t>(c.height) - f->fmt.pix.height);
          if (best == nullptr || d < best_d) {
            best = &c;
            best_d = d;
          }
        }
        fmt_ = best != nullptr ? *best : opt_.formats.front();
        bytesperline_ = fmt_.width * bytes_pp(fmt_.fourcc);
        sizeimage_ = bytesperline_ * fmt_.height;
      }
      f->fmt.pix.width = fmt_.width;
      f->fmt.pix.height = fmt_.height;
      f->fmt.pix.pixelformat = fmt_.fourcc;
      f->fmt.pix.bytesperline = bytesperline_;
      f->fmt.pix.sizeimage = sizeimage_;
      f->fmt.pix.field = V4L2_FIELD_NONE;
      return 0;
    }
    case VIDIOC_S_PARM: {
      auto* p = static_cast<v4l2_streamparm*>(arg);
      const auto& t = p->parm.capture.timeperframe;
      if (t.numerator == 0 || t.denominator == 0) return -EINVAL;
      rate_hz_ = std::min(opt_.max_rate_hz, static_cast<double>(t.denominator) / t.numerator);
      if (!opt_.frame_rates.empty()) {  // the nearest it offers
        const double want = rate_hz_;
        rate_hz_ = *std::min_element(opt_.frame_rates.begin(), opt_.frame_rates.end(),
                                     [&](double a, double b) { return std::fabs(a - want) < std::fabs(b - want); });
      }
      p->parm.capture.timeperframe.numerator = 1000;
      p->parm.capture.timeperframe.denominator = static_cast<std::uint32_t>(std::lround(rate_hz_ * 1000));
      return 0;
    }
    case VIDIOC_S_CTRL: {
      auto* c = static_cast<v4l2_control*>(arg);
      if (c->id == V4L2_CID_EXPOSURE_ABSOLUTE) {
        counters_.exposure_100us = static_cast<std::uint32_t>(c->value);
      } else if (c->id == V4L2_CID_GAIN) {
        if (c->value < opt_.gain_min || c->value > opt_.gain_max) return -ERANGE;
        counters_.gain = c->value;
      } else if (c->id != V4L2_CID_EXPOSURE_AUTO) {
        return -EINVAL;
      }
      return 0;
    }
    case VIDIOC_G_CTRL: {
      auto* c = static_cast<v4l2_control*>(arg);
      if (c->id == V4L2_CID_EXPOSURE_ABSOLUTE && counters_.exposure_100us > 0) c->value = static_cast<std::int32_t>(counters_.exposure_100us);
      else if (c->id == V4L2_CID_GAIN) c->value = counters_.gain >= 0 ? counters_.gain : opt_.gain_default;
      else return -EINVAL;
      return 0;
    }
    case VIDIOC_QUERYCTRL: {
      auto* q = static_cast<v4l2_queryctrl*>(arg);
      if (q->id != V4L2_CID_GAIN) return -EINVAL;
      q->type = V4L2_CTRL_TYPE_INTEGER;
      q->minimum = opt_.gain_min;
      q->maximum = opt_.gain_max;
      q->step = opt_.gain_step;
      q->default_value = opt_.gain_default;
      q->flags = 0;
      return 0;
    }
    case VIDIOC_REQBUFS: {
      auto* r = static_cast<v4l2_requestbuffers*>(arg);
      if (r->memory != V4L2_MEMORY_MMAP) return -EINVAL;
      if (streaming_) return -EBUSY;
      buffers_.clear();
      queue_.clear();
      r->count = std::min(r->count, opt_.max_buffers);
      buffers_.resize(r->count);
      for (auto& b : buffers_) b.mem.assign(sizeimage_, 0);
      return 0;
    }
    case VIDIOC_QUERYBUF:
    case VIDIOC_QBUF: {
      auto* b = static_cast<v4l2_buffer*>(arg);
      if (b->index >= buffers_.size() || b->memory != V4L2_MEMORY_MMAP) return -EINVAL;
      auto& buf = buffers_[b->index];
      if (request == VIDIOC_QUERYBUF) {
        b->length = static_cast<std::uint32_t>(buf.mem.size());
        b->m.offset = static_cast<std::uint32_t>(b->index * kPage);
        return 0;
      }
      if (buf.queued) return -EINVAL;
      buf.queued = true;
      buf.filled = false;
      queue_.push_back(b->index);
      return 0;
    }
    case VIDIOC_DQBUF: {
      auto* b = static_cast<v4l2_buffer*>(arg);
      Buffer* oldest = nullptr;
      std::uint32_t index = 0;
      for (std::uint32_t i = 0; i < buffers_.size(); ++i)
        if (buffers_[i].filled && (oldest == nullptr || buffers_[i].sequence < oldest->sequence)) {
          oldest = &buffers_[i];
          index = i;
        }
      if (oldest == nullptr) return -EAGAIN;
      write_truth(oldest->truth, truth::Fate::kSent, 0);
      flush_truth_locked();  // on disk before the consumer has the frame (and the rig publishes it)
      oldest->filled = false;
      oldest->queued = false;
      b->index = index;
      b->bytesused = oldest->bytesused;
      b->sequence = oldest->sequence;
      b->field = V4L2_FIELD_NONE;
      b->flags = opt_.timestamp_type | oldest->stamp_source;
      const Nanos stamp = oldest->stamp_mono + oldest->mono_to_stamp_clock;
      b->timestamp.tv_sec = static_cast<time_t>(stamp / 1'000'000'000);
      b->timestamp.tv_usec = static_cast<suseconds_t>((stamp % 1'000'000'000) / 1000);
      return 0;
    }
    case VIDIOC_SUBSCRIBE_EVENT:
    case VIDIOC_UNSUBSCRIBE_EVENT: {
      const auto* sub = static_cast<const v4l2_event_subscription*>(arg);
      if (!opt_.frame_sync_events || sub->type != V4L2_EVENT_FRAME_SYNC) return -EINVAL;
      sync_subscribed_ = request == VIDIOC_SUBSCRIBE_EVENT;
      if (!sync_subscribed_) sync_events_.clear();
      return 0;
    }
    case VIDIOC_DQEVENT: {
      if (sync_events_.empty()) return -ENOENT;
      auto* ev = static_cast<v4l2_event*>(arg);
      *ev = {};
      ev->type = V4L2_EVENT_FRAME_SYNC;
      ev->u.frame_sync.frame_sequence = sync_events_.front();
      sync_events_.pop_front();
      ev->pending = static_cast<std::uint32_t>(sync_events_.size());
      ev->sequence = event_count_++;
      return 0;
    }
    case VIDIOC_STREAMON:
      if (buffers_.empty()) return -EINVAL;
      if (streaming_) return 0;
      streaming_ = true;
      // Drivers number a stream's frames from 0 (vb2 drivers, uvcvideo): frames lost at its very
      // start show in the first buffer's sequence. The truth's unit keeps the stream's ordinal
      // above the 32-bit sequence, so units stay unique and increasing.
      if (streams_++ > 0) sequence_ = 0;
      next_due_ = monotonic_now_ns();
      return 0;
    case VIDIOC_STREAMOFF:
      streaming_ = false;
      settle_filled_locked(truth::Fate::kSent, 0);  // delivered: the consumer let them go
      for (auto& b : buffers_) b.queued = b.filled = false;
      queue_.clear();
      return 0;
    default:
      return -ENOTTY;
  }
}

bool FakeV4l2Device::fill_one(Nanos due) {
  while (!queue_.empty()) {
    auto& b = buffers_[queue_.front()];
    queue_.pop_front();
    if (!b.queued || b.filled) continue;
    const auto seq = sequence_++;
    std::memset(b.mem.data(), static_cast<int>(seq & 0xff), sizeimage_);
    std::memcpy(b.mem.data(), &seq, std::min<std::size_t>(sizeof seq, sizeimage_));
    b.sequence = seq;
    b.stamp_mono = due;
    b.mono_to_stamp_clock = opt_.realtime_stamps ? clock_pair_now().vehicle_minus_monotonic() : 0;
    b.stamp_source = V4L2_BUF_FLAG_TSTAMP_SRC_SOE;
    Nanos exposure_start = due;
    const auto* mode = schedule_.active("v4l2.stamp_mode", schedule_.seconds(due));
    if (mode != nullptr && mode->text("mode", "eof") == "eof") {
      // Stamped at the end of the frame: this frame's exposure began exposure + readout earlier.
      b.stamp_source = V4L2_BUF_FLAG_TSTAMP_SRC_EOF;
      const Nanos exposure = counters_.exposure_100us > 0 ? Nanos{counters_.exposure_100us} * 100'000 : kDefaultExposureNs;
      exposure_start = due - exposure - static_cast<Nanos>(0.5e9 / rate_hz_);
    }
    // Every stamp_mode fault acting now is recorded, also one overlapping another (the first decides
    // the mode): the second of two identical ones planned 6 ms apart was in no truth record (ten-minute
    // campaign, seed 6: faults_injected broken).
    if (mode != nullptr)
      for (const auto& e : schedule_.events())
        if (e.kind == "v4l2.stamp_mode" && e.active_at(schedule_.seconds(due)))
          fault_line(e, unit_of(seq), "buffer timestamps: " + mode->text("mode", "eof") +
                                          (e.id == mode->id ? "" : " (fault " + std::to_string(mode->id) + "'s mode)"));
    b.truth = frame_truth(seq, exposure_start, due + b.mono_to_stamp_clock);  // written as it leaves the driver
    b.bytesused = short_every_ != 0 && (seq + 1) % short_every_ == 0 ? sizeimage_ / 2 : sizeimage_;
    b.filled = true;
    ++counters_.frames;
    return true;
  }
  // No buffer queued: the frame was exposed and is lost in the driver (the consumer's fault).
  record(sequence_++, due, due, truth::Fate::kDropped, 0);
  ++counters_.dropped;
  return false;
}

// One frame slot at `due`: a sequence gap's drop, a queued buffer filled, or a frame dropped for
// want of one.
void FakeV4l2Device::make_slot_locked(Nanos due) {
  frame_sync_locked(sequence_);  // every path below takes this slot's sequence, filled or dropped
  if (gap_left_ == 0)
    for (const auto& e : schedule_.events())
      if (e.kind == "v4l2.sequence_gap" && schedule_.seconds(due) >= e.at_s && gaps_done_.insert(e.id).second) {
        gap_left_ = static_cast<std::uint32_t>(std::max(0.0, e.number("n", 3)));
        gap_fault_ = e.id;
        // Planned while the device made no frames (gone, closed, not streaming): it drops the
        // stream's next ones, and its line says when that was.
        const double late_s = schedule_.seconds(due) - e.at_s;
        const bool late = late_s > 1.5 / rate_hz_;
        fault_line(e, unit_of(sequence_),
                   "the device skips " + std::to_string(gap_left_) + " frames (sequence jumps)" +
                       (late ? "; planned " + std::to_string(late_s) + " s earlier, while it made no frames" : ""),
                   late ? schedule_.seconds(due) : -1.0);
        break;
      }
  if (gap_left_ > 0) {  // the device drops this slot's frame itself: its sequence moves on
    // A frame made and lost in the device or its driver (what a real sequence gap is: uvcvideo
    // counts the frames it drops), so `dropped`, a loss the rig must count (its `missing_frames`),
    // not `not_sent` (issue 27 item 5).
    --gap_left_;
    record(sequence_++, due, due, truth::Fate::kDropped, gap_fault_);
    return;
  }
  (void)fill_one(due);
}

// The frame's start, before the device knows whether a buffer takes it: the event of a dropped
// frame too (its sequence is the one the next buffer skips).
void FakeV4l2Device::frame_sync_locked(std::uint32_t seq) {
  if (!sync_subscribed_) return;
  constexpr std::size_t kKept = 4;  // the kernel keeps a subscription's newest `elems`
  if (sync_events_.size() == kKept) sync_events_.pop_front();
  sync_events_.push_back(seq);
  ++counters_.frame_syncs;
}

int FakeV4l2Device::poll(int fd, int timeout_ms) {
  const Nanos deadline = monotonic_now_ns() + static_cast<Nanos>(timeout_ms) * 1'000'000;
  for (;;) {
    Nanos wake = deadline;
    {
      std::lock_guard lock(mutex_);
      if (fd != fd_) return -EBADF;
      apply_faults_locked();
      if (gone()) return -ENODEV;
      const Nanos now = monotonic_now_ns();
      if (streaming_ && !stalled_) {
        // Every slot due by now is made, also those a late consumer missed (a capture thread that
        // waited on something): its queued buffers filled at their slots, the rest dropped for
        // want of one, as a device's. (One slot per poll, resynced to now, made the device run at
        // the consumer's pace and its truth silent about the frames it would have made.)
        while (now >= next_due_) {
          const Nanos due = next_due_;
          next_due_ += static_cast<Nanos>(1e9 / rate_hz_);
          make_slot_locked(due);
        }
        // On disk before the consumer can dequeue one of these frames (and the rig publish it).
        flush_truth_locked();
        wake = std::min(wake, next_due_);
      }
      for (const auto& b : buffers_)
        if (b.filled) return 1;
      if (now >= deadline) return 0;
      // Faults must take effect quickly: never sleep more than 10 ms at once.
      wake = std::min(wake, now + 10'000'000);
    }
    sleep_ns(wake - monotonic_now_ns());
  }
}

void FakeV4l2Device::record(std::uint32_t seq, Nanos acq_mono, Nanos dev_mono, truth::Fate fate, std::uint64_t fault) {
  if (truth_ == nullptr) return;
  auto t = frame_truth(seq, acq_mono, dev_mono);
  write_truth(t, fate, fault);
}

FakeV4l2Device::Buffer::Truth FakeV4l2Device::frame_truth(std::uint32_t seq, Nanos acq_mono, Nanos dev_mono) const {
  const Nanos to_vehicle = clock_pair_now().vehicle_minus_monotonic();  // not two bare reads: see clock.hpp
  // The buffer's timestamp is a timeval: what the device says is whole microseconds.
  return {true, seq, acq_mono + to_vehicle, dev_mono / 1000 * 1000, vehicle_now_ns()};
}

void FakeV4l2Device::write_truth(Buffer::Truth& t, truth::Fate fate, std::uint64_t fault) {
  if (truth_ == nullptr || !t.pending) return;
  t.pending = false;
  truth_->frame(unit_of(t.seq), t.acq_ns, t.dev_ns, t.done_ns, fate, fault);
  truth_unflushed_ = true;
}

void FakeV4l2Device::settle_filled_locked(truth::Fate fate, std::uint64_t fault) {
  for (auto& b : buffers_) {
    if (!b.filled) continue;
    write_truth(b.truth, fate, fault);
    if (fate == truth::Fate::kDropped) b.filled = false;
  }
  flush_truth_locked();
}

// Once per call, not per line: a late consumer's poll makes several slots, a return many not_sent
// ones. Without it the frame lines sat in the writer's buffer until it filled or the device's last
// owner let it go (only the fault lines were flushed): a reader saw no return's not_sent slots, a
// killed driver took the last 4-64 KiB of frames it had published with it.
void FakeV4l2Device::flush_truth_locked() {
  if (!truth_unflushed_) return;
  truth_->flush();
  truth_unflushed_ = false;
}

std::int64_t FakeV4l2Device::unit_of(std::uint32_t seq) const noexcept {
  const std::int64_t stream = streams_ > 0 ? static_cast<std::int64_t>(streams_ - 1) : 0;
  return stream * (std::int64_t{1} << 32) + seq;
}

void FakeV4l2Device::fault_line(const faults::FaultEvent& e, std::int64_t unit, const std::string& detail, double at_s) {
  if (truth_ == nullptr) return;
  const double from = at_s >= 0 ? at_s : e.at_s;
  truth_->fault(e, schedule_.vehicle_ns(from), schedule_.vehicle_ns(std::max(from, e.at_s + e.duration_s)), unit, detail);
}

// Every v4l2.disconnect whose start has passed is recorded, once, whenever the fake first hears of
// it: one that begins while the device is already gone (two overlapping) extends the absence, one
// that began and ended while nobody called (the device closed, the rig between reopens) was an
// absence nobody saw. Both were in no truth record (the 10-minute campaign's faults_injected).
void FakeV4l2Device::apply_faults_locked() {
  if (schedule_.events().empty()) return;
  const Nanos now = monotonic_now_ns();
  const double t = schedule_.seconds(now);
  const auto* active = schedule_.active("v4l2.disconnect", t);
  if (active != nullptr && !fault_disconnected_) {
    // The slots due before it went were made (the consumer not polling does not stop a device);
    // from its start on, none (before, slots between the consumer's last call and now were in no
    // record at all).
    const Nanos gone_at = std::min(now, schedule_.mono_ns(active->at_s));
    const auto period = static_cast<Nanos>(1e9 / rate_hz_);
    if (streaming_ && !stalled_)
      for (; next_due_ < gone_at; next_due_ += period) make_slot_locked(next_due_);
    fault_disconnected_ = true;
    disconnected_at_ = streaming_ ? std::max(gone_at, next_due_) : 0;  // a device not streaming misses no frame
    disconnect_fault_ = active->id;
    disconnect_until_s_ = active->at_s + active->duration_s;
    disconnects_seen_.insert(active->id);
    fault_line(*active, unit_of(sequence_), "the device is gone (ENODEV), then returns");
    settle_filled_locked(truth::Fate::kDropped, active->id);  // done, never dequeued: gone with it
  }
  for (const auto& e : schedule_.events()) {
    if (e.kind != "v4l2.disconnect" || e.at_s > t || !disconnects_seen_.insert(e.id).second) continue;
    if (e.active_at(t)) {
      disconnect_until_s_ = std::max(disconnect_until_s_, e.at_s + e.duration_s);
      fault_line(e, unit_of(sequence_), "the device is gone (ENODEV) already (fault " + std::to_string(disconnect_fault_) +
                                   "): gone until this one ends too");
      continue;
    }
    // Over before anything was asked of the device: gone for that time all the same (an open would
    // have failed). A stream running through it (its consumer not polling) is lost with the device.
    fault_line(e, unit_of(sequence_), "the device was gone (ENODEV) and back before anything was asked of it");
    if (fault_disconnected_ && e.at_s <= disconnect_until_s_) disconnect_until_s_ = std::max(disconnect_until_s_, e.at_s + e.duration_s);
    if (!fault_disconnected_ && streaming_) {
      fault_disconnected_ = true;
      disconnected_at_ = std::max(schedule_.mono_ns(e.at_s), next_due_);  // the slots not made yet
      disconnect_fault_ = e.id;
      settle_filled_locked(truth::Fate::kDropped, e.id);
      end_disconnect_locked(schedule_.mono_ns(e.at_s + e.duration_s));
    }
  }
  // Back at the end of its last disconnect (the first call after it may come seconds later: the
  // slots between were a returned device's, not streaming, and made nothing).
  if (active == nullptr && fault_disconnected_) end_disconnect_locked(std::min(now, schedule_.mono_ns(disconnect_until_s_)));
}

// It returns. The frames its clock would have had meanwhile were never made: not_sent, numbered on
// from the lost stream (the next STREAMON numbers from 0 again, as drivers do).
void FakeV4l2Device::end_disconnect_locked(Nanos until) {
  fault_disconnected_ = false;
  if (disconnected_at_ > 0) {
    const auto period = static_cast<Nanos>(1e9 / rate_hz_);
    for (Nanos slot = disconnected_at_; slot < until; slot += period) record(sequence_++, slot, slot, truth::Fate::kNotSent, disconnect_fault_);
    flush_truth_locked();  // back: what it did not make while gone is in the record now
  }
  disconnected_at_ = 0;
  streaming_ = false;  // what was streaming is gone with the device
}

}  // namespace sensor_rig::camera::mock
