#include "sensor_rig/camera/v4l2_source.hpp"

#include <linux/videodev2.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "sensor_rig/common/log.hpp"

namespace sensor_rig::camera {
namespace {

// An exposure the device does not report (auto exposure, no V4L2_CID_EXPOSURE_ABSOLUTE read back):
// the figure UVC cameras run at indoors; its error is the stamp's error under end-of-frame stamps.
constexpr double kAssumedExposureUs = 10'000.0;

Nanos timeval_ns(const timeval& tv) {
  return static_cast<Nanos>(tv.tv_sec) * 1'000'000'000 + static_cast<Nanos>(tv.tv_usec) * 1000;
}

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// A buffer is at least this old at its dequeue only when the consumer fell behind by every buffer;
// a stamp older than that (or after the dequeue) is not on the clock it is taken to be on.
constexpr Nanos kStampSlackNs = 1'000'000'000;

// A stream's first sequence below this is frames lost since STREAMON (drivers count from 0); at or
// above it the driver does not restart its count.
constexpr std::uint32_t kMaxStartSequence = 1000;

}  // namespace

V4l2Source::V4l2Source(SourceConfig cfg, std::shared_ptr<V4l2Device> dev) : cfg_(std::move(cfg)), dev_(std::move(dev)) {
  if (!dev_) throw CameraError("v4l2: no device layer");
  if (!backend_supports("v4l2", cfg_.format))
    throw CameraError("v4l2 " + cfg_.device + ": pixel format not supported (supported: " + pixel_format_names("v4l2") + ")");
}

V4l2Source::~V4l2Source() { close(); }

std::string V4l2Source::describe() const {
  return "v4l2 " + cfg_.device + " " + info(cfg_.format).v4l2_name + " " + std::to_string(cfg_.width) + "x" +
         std::to_string(cfg_.height) + "@" + std::to_string(static_cast<int>(std::lround(cfg_.frame_rate)));
}

void V4l2Source::fail(const std::string& what, int rc) {
  const std::string msg = "v4l2 " + cfg_.device + ": " + what + (rc < 0 ? std::string(": ") + std::strerror(-rc) : "");
  close();
  throw CameraError(msg);
}

void V4l2Source::open() {
  close();
  const int fd = dev_->open(cfg_.device);
  if (fd < 0) fail("open", fd);
  fd_ = fd;
  have_sequence_ = false;
  stamp_warned_ = false;
  v4l2_capability cap{};
  if (const int rc = dev_->ioctl(fd_, VIDIOC_QUERYCAP, &cap); rc < 0) fail("VIDIOC_QUERYCAP", rc);
  const std::uint32_t caps = (cap.capabilities & V4L2_CAP_DEVICE_CAPS) != 0 ? cap.device_caps : cap.capabilities;
  if ((caps & V4L2_CAP_VIDEO_CAPTURE) == 0) fail("not a video capture device", 0);
  if ((caps & V4L2_CAP_STREAMING) == 0) fail("no streaming I/O", 0);
  negotiate_format();
  set_rate_and_controls();
  // Frame-start events, where the driver sends them (CSI receivers; not uvcvideo): the sequence of
  // every frame the device began, also one it then dropped for want of a buffer. Subscribed before
  // STREAMON, so the stream's first frame has its event. Taken as numbered like the buffers (the
  // spec's frame_sequence: "the sequence number of the frame being received").
  have_device_sequence_ = false;
  v4l2_event_subscription sub{};
  sub.type = V4L2_EVENT_FRAME_SYNC;
  frame_sync_ = dev_->ioctl(fd_, VIDIOC_SUBSCRIBE_EVENT, &sub) == 0;
  start_streaming();
}

void V4l2Source::negotiate_format() {
  const auto& fi = info(cfg_.format);
  // What the device offers, for the error message when the wanted format is not among them.
  std::string offered;
  bool found = false;
  for (std::uint32_t i = 0; i < 64; ++i) {
    v4l2_fmtdesc d{};
    d.index = i;
    d.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (dev_->ioctl(fd_, VIDIOC_ENUM_FMT, &d) < 0) break;
    offered += (offered.empty() ? "" : ", ") + fourcc_string(d.pixelformat);
    found = found || d.pixelformat == fi.v4l2;
  }
  if (!found) fail(std::string("device does not offer ") + fi.v4l2_name + " (offers: " + offered + ")", 0);
  v4l2_format f{};
  f.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  f.fmt.pix.width = cfg_.width;
  f.fmt.pix.height = cfg_.height;
  f.fmt.pix.pixelformat = fi.v4l2;
  f.fmt.pix.field = V4L2_FIELD_NONE;
  if (const int rc = dev_->ioctl(fd_, VIDIOC_S_FMT, &f); rc < 0) fail("VIDIOC_S_FMT", rc);
  // The driver may adjust: accept only exactly what was asked (the calibration is for that size).
  if (f.fmt.pix.pixelformat != fi.v4l2 || f.fmt.pix.width != cfg_.width || f.fmt.pix.height != cfg_.height)
    fail("device gives " + fourcc_string(f.fmt.pix.pixelformat) + " " + std::to_string(f.fmt.pix.width) + "x" +
             std::to_string(f.fmt.pix.height) + " instead of the configured format",
         0);
  const std::uint32_t tight = row_step(cfg_.format, cfg_.width);
  step_ = f.fmt.pix.bytesperline >= tight ? f.fmt.pix.bytesperline : tight;
  image_bytes_ = step_ * cfg_.height;
}

void V4l2Source::set_rate_and_controls() {
  v4l2_streamparm p{};
  p.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  p.parm.capture.timeperframe.numerator = 1000;
  p.parm.capture.timeperframe.denominator = static_cast<std::uint32_t>(std::lround(cfg_.frame_rate * 1000.0));
  const int prc = dev_->ioctl(fd_, VIDIOC_S_PARM, &p);
  if (prc < 0 && prc != -ENOTTY) fail("VIDIOC_S_PARM", prc);
  // The interval the driver granted (it may round or refuse the asked rate): the readout model's period.
  const auto& tpf = p.parm.capture.timeperframe;
  const bool granted = prc == 0 && tpf.denominator > 0 && tpf.numerator > 0;
  period_ns_ = granted ? static_cast<Nanos>(1e9 * tpf.numerator / tpf.denominator)
                       : static_cast<Nanos>(1e9 / std::max(cfg_.frame_rate, 1.0));
  granted_rate_hz_ = granted ? static_cast<double>(tpf.denominator) / tpf.numerator : cfg_.frame_rate;
  // UVC devices offer a few discrete intervals and round to one; others refuse the rate and keep
  // theirs: the camera then runs at a rate nobody configured (the watchdog, the sync sets, the
  // readout model all assume the asked one).
  if (!granted)
    log::warn("camera", "v4l2 " + cfg_.device + ": the frame rate cannot be set or read (VIDIOC_S_PARM " +
                            (prc < 0 ? std::string(std::strerror(-prc)) : std::string("gave no interval")) + "): " +
                            fixed(cfg_.frame_rate, 3) + " Hz assumed");
  else if (std::fabs(granted_rate_hz_ - cfg_.frame_rate) > 0.005 * cfg_.frame_rate)
    log::warn("camera", "v4l2 " + cfg_.device + ": frame rate " + fixed(cfg_.frame_rate, 3) + " Hz asked, " +
                            fixed(granted_rate_hz_, 3) + " Hz granted (interval " + std::to_string(tpf.numerator) + "/" +
                            std::to_string(tpf.denominator) + " s): set frame_rate to one the device offers (v4l2-ctl --list-formats-ext)");
  exposure_us_ = 0.0;
  if (cfg_.exposure_us > 0) {
    v4l2_control manual{V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_MANUAL};
    (void)dev_->ioctl(fd_, VIDIOC_S_CTRL, &manual);  // not every device has auto exposure
    // V4L2_CID_EXPOSURE_ABSOLUTE is in units of 100 µs.
    v4l2_control c{V4L2_CID_EXPOSURE_ABSOLUTE, std::max<std::int32_t>(1, static_cast<std::int32_t>(std::lround(cfg_.exposure_us / 100.0)))};  // < 50 us: 1, not 0
    if (const int rc = dev_->ioctl(fd_, VIDIOC_S_CTRL, &c); rc < 0) fail("exposure (V4L2_CID_EXPOSURE_ABSOLUTE)", rc);
    exposure_us_ = static_cast<double>(c.value) * 100.0;
  }
  // What the device has (its own, or the rounded one set): read back where it answers.
  v4l2_control g{V4L2_CID_EXPOSURE_ABSOLUTE, 0};
  if (dev_->ioctl(fd_, VIDIOC_G_CTRL, &g) == 0 && g.value > 0) exposure_us_ = static_cast<double>(g.value) * 100.0;
  gain_db_ = -1.0;
  if (cfg_.gain_db >= 0) set_gain();
}

// V4L2_CID_GAIN is in the driver's own units (a register code, 1/16 steps, 0.1 dB...): gain_db is
// converted with the configured units per dB from the control's minimum (0 dB), on its step, and
// refused beyond its maximum; it was written as raw units (3 dB -> 3).
void V4l2Source::set_gain() {
  v4l2_queryctrl q{};
  q.id = V4L2_CID_GAIN;
  if (const int rc = dev_->ioctl(fd_, VIDIOC_QUERYCTRL, &q); rc < 0 || (q.flags & V4L2_CTRL_FLAG_DISABLED) != 0)
    fail("gain (V4L2_CID_GAIN): the device has no gain control", rc < 0 ? rc : 0);
  if (!(cfg_.v4l2_gain_units_per_db > 0))
    fail("gain_db needs gain_units_per_db: V4L2_CID_GAIN has no unit (this device: " + std::to_string(q.minimum) + ".." +
             std::to_string(q.maximum) + ", default " + std::to_string(q.default_value) + ")",
         0);
  const double per_db = cfg_.v4l2_gain_units_per_db;
  const double step = q.step > 0 ? static_cast<double>(q.step) : 1.0;
  const double units = std::round(cfg_.gain_db * per_db / step) * step;
  const double raw = static_cast<double>(q.minimum) + units;
  if (raw > static_cast<double>(q.maximum))
    fail("gain_db " + fixed(cfg_.gain_db, 2) + " beyond the device's maximum of " +
             fixed(static_cast<double>(q.maximum - q.minimum) / per_db, 2) + " dB (V4L2_CID_GAIN " + std::to_string(q.minimum) +
             ".." + std::to_string(q.maximum) + " at " + fixed(per_db, 3) + " per dB)",
         0);
  v4l2_control c{V4L2_CID_GAIN, static_cast<std::int32_t>(raw)};
  if (const int rc = dev_->ioctl(fd_, VIDIOC_S_CTRL, &c); rc < 0) fail("gain (V4L2_CID_GAIN)", rc);
  v4l2_control g{V4L2_CID_GAIN, 0};
  const std::int32_t applied = dev_->ioctl(fd_, VIDIOC_G_CTRL, &g) == 0 ? g.value : c.value;
  gain_db_ = static_cast<double>(applied - q.minimum) / per_db;
}

Nanos V4l2Source::eof_offset_ns() const noexcept {
  const double exposure = exposure_us_ > 0 ? exposure_us_ : kAssumedExposureUs;
  const Nanos readout = cfg_.readout_us > 0 ? static_cast<Nanos>(cfg_.readout_us * 1000.0) : period_ns_ / 2;
  return static_cast<Nanos>(exposure * 1000.0) + readout;
}

// The buffer's timestamp on CLOCK_MONOTONIC. The flag says which clock it is on: MONOTONIC (every
// capture driver since Linux 3.9); UNKNOWN (older drivers: gettimeofday, CLOCK_REALTIME) or COPY
// (the producer's stamp). One not on CLOCK_MONOTONIC was taken as if it were: a CLOCK_REALTIME stamp
// became an exposure start decades off. Now a stamp that is not MONOTONIC is taken as CLOCK_REALTIME
// where that is plausible (at most kStampSlackNs + the buffers' span before the dequeue), and any
// stamp plausible on neither clock (after its dequeue, or older) is replaced by the dequeue time:
// the frame's end (an end-of-frame stamp, which the caller moves back by exposure + readout).
// Counted; warned once per open.
Nanos V4l2Source::buffer_stamp_mono(const v4l2_buffer& b, Nanos real, Nanos mono, bool& eof) noexcept {
  const Nanos raw = timeval_ns(b.timestamp);
  const Nanos window = kStampSlackNs + period_ns_ * static_cast<Nanos>(buffers_.size());
  const auto plausible = [&](Nanos t) { return t <= mono && t >= mono - window; };
  const std::uint32_t type = b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK;
  Nanos t = raw;
  std::string why;
  if (type != V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC) {
    ++stamp_checks_.not_monotonic;
    why = std::string("buffer timestamps not on CLOCK_MONOTONIC (") +
          (type == V4L2_BUF_FLAG_TIMESTAMP_COPY ? "COPY" : type == V4L2_BUF_FLAG_TIMESTAMP_UNKNOWN ? "UNKNOWN" : "?") +
          "): taken as CLOCK_REALTIME where plausible";
    if (!plausible(raw) && plausible(raw - (real - mono))) t = raw - (real - mono);
  }
  if (!plausible(t)) {
    ++stamp_checks_.replaced;
    why += std::string(why.empty() ? "" : "; ") + "a buffer stamped " + fixed(static_cast<double>(mono - t) * 1e-6, 1) +
           " ms before its dequeue: the dequeue time taken as its end of frame";
    t = mono;
    eof = true;
  }
  if (!why.empty() && !stamp_warned_) {
    stamp_warned_ = true;
    log::warn("camera", "v4l2 " + cfg_.device + ": " + why);
  }
  return t;
}

void V4l2Source::start_streaming() {
  v4l2_requestbuffers req{};
  req.count = static_cast<std::uint32_t>(cfg_.buffers);
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  if (const int rc = dev_->ioctl(fd_, VIDIOC_REQBUFS, &req); rc < 0) fail("VIDIOC_REQBUFS", rc);
  if (req.count < 2) fail("device granted fewer than 2 buffers", 0);
  buffers_.resize(req.count);
  for (std::uint32_t i = 0; i < req.count; ++i) {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    b.memory = V4L2_MEMORY_MMAP;
    b.index = i;
    if (const int rc = dev_->ioctl(fd_, VIDIOC_QUERYBUF, &b); rc < 0) fail("VIDIOC_QUERYBUF", rc);
    if (b.length < image_bytes_) fail("buffer smaller than one image", 0);
    void* p = dev_->mmap(b.length, fd_, static_cast<off_t>(b.m.offset));
    if (p == nullptr) fail("mmap", -ENOMEM);
    buffers_[i] = {p, b.length};
    if (const int rc = dev_->ioctl(fd_, VIDIOC_QBUF, &b); rc < 0) fail("VIDIOC_QBUF", rc);
  }
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (const int rc = dev_->ioctl(fd_, VIDIOC_STREAMON, &type); rc < 0) fail("VIDIOC_STREAMON", rc);
  streaming_ = true;
}

void V4l2Source::requeue(std::uint32_t index) noexcept {
  if (fd_ < 0 || index >= buffers_.size()) return;
  v4l2_buffer b{};
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_MMAP;
  b.index = index;
  (void)dev_->ioctl(fd_, VIDIOC_QBUF, &b);  // fails only when the device is gone: next() reports that
}

// Sequence gaps: frames the device (or its driver) made and never handed out. Drivers number a
// stream from 0 at STREAMON (vb2, uvcvideo), so the first buffer's sequence is the frames lost
// at the stream's start: a gap there (a device dropping its first frames after a reopen) was
// invisible (the 10-minute campaign's corner_rear_right frames 86-88: a gap planned while the
// device was gone, which fired at the reopened stream's first slots). A first
// sequence of 1000 or more is a driver that does not restart it: nothing to count then.
void V4l2Source::count_sequence(std::uint32_t sequence) noexcept {
  if (have_sequence_ && sequence > last_sequence_ + 1 && sequence - last_sequence_ < 1000)
    stats_.missing_frames += sequence - last_sequence_ - 1;
  else if (!have_sequence_ && sequence < kMaxStartSequence)
    stats_.missing_frames += sequence;
  last_sequence_ = sequence;
  have_sequence_ = true;
}

// Non-blocking (ENOENT when none is pending); the kernel keeps a subscription's newest events and
// drops its oldest, so the latest frame start is always there. Read at every poll, so a device that
// then vanishes (ENODEV to every ioctl) has told what it began before.
void V4l2Source::read_frame_syncs() noexcept {
  if (!frame_sync_ || fd_ < 0) return;
  for (int n = 0; n < 64; ++n) {
    v4l2_event ev{};
    if (dev_->ioctl(fd_, VIDIOC_DQEVENT, &ev) < 0) return;
    if (ev.type == V4L2_EVENT_FRAME_SYNC) {
      device_sequence_ = ev.u.frame_sync.frame_sequence;
      have_device_sequence_ = true;
    }
    if (ev.pending == 0) return;
  }
}

// Frames the device began after the last buffer dequeued (or drained at the close) that no buffer
// brought: dropped for want of a queued buffer, or discarded by STREAMOFF mid-frame. Their gap would
// show only in the next buffer's sequence, which never comes from this open (the next STREAMON
// numbers from 0), so they were neither published nor counted (issue 27 item 5). Counted here, once:
// last_sequence_ moves to the device's, and the next open's first sequence counts only its own
// stream. What a real device cannot tell: without FRAME_SYNC events (uvcvideo offers none) the
// frames between the last dequeue and the close are unknown (a device that stalled or was unplugged
// made none, one whose consumer held every buffer dropped them all) and nothing is counted; a frame
// whose start the driver never signalled (the device gone first) is not counted either.
void V4l2Source::count_unseen_tail() noexcept {
  if (!have_device_sequence_) return;
  if (!have_sequence_) {
    if (device_sequence_ < kMaxStartSequence) stats_.missing_frames += device_sequence_ + 1;  // 0..it, none dequeued
  } else if (device_sequence_ > last_sequence_ && device_sequence_ - last_sequence_ < 1000) {
    stats_.missing_frames += device_sequence_ - last_sequence_;
  } else {
    return;  // behind the last buffer (events lag), or a count that is not this stream's
  }
  last_sequence_ = device_sequence_;
  have_sequence_ = true;
}

void V4l2Source::close() noexcept {
  if (fd_ < 0) return;
  if (streaming_) {
    // Frames the device filled and nobody dequeued (the consumer was behind, or the watchdog gave
    // up): made and never published, and STREAMOFF discards them. Counted lost here, as every
    // source counts what its stream holds at a close (issue 27: the count restarted with each
    // open, and these were neither published nor counted). The fd is non-blocking: EAGAIN ends it.
    for (int n = 0; n < 64; ++n) {
      v4l2_buffer b{};
      b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      b.memory = V4L2_MEMORY_MMAP;
      if (dev_->ioctl(fd_, VIDIOC_DQBUF, &b) < 0) break;
      count_sequence(b.sequence);
      ++stats_.missing_frames;
    }
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    (void)dev_->ioctl(fd_, VIDIOC_STREAMOFF, &type);
    streaming_ = false;
    // After STREAMOFF: a frame begun after the drain above, discarded by it, has its event too.
    read_frame_syncs();
    count_unseen_tail();
  }
  frame_sync_ = false;  // the subscription ends with the file handle
  for (auto& m : buffers_)
    if (m.addr != nullptr) (void)dev_->munmap(m.addr, m.length);
  buffers_.clear();
  v4l2_requestbuffers req{};
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  (void)dev_->ioctl(fd_, VIDIOC_REQBUFS, &req);
  (void)dev_->close(fd_);
  fd_ = -1;
}

Capture V4l2Source::next(int timeout_ms) {
  Capture c;
  if (fd_ < 0) {
    c.status = CaptureStatus::kDisconnected;
    c.error = "not open";
    return c;
  }
  const int pr = dev_->poll(fd_, timeout_ms);
  if (pr >= 0) read_frame_syncs();
  if (pr == 0) {
    ++stats_.timeouts;
    c.status = CaptureStatus::kTimeout;
    return c;
  }
  v4l2_buffer b{};
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_MMAP;
  const int rc = pr < 0 ? pr : dev_->ioctl(fd_, VIDIOC_DQBUF, &b);
  if (rc == -EAGAIN) {
    ++stats_.timeouts;
    c.status = CaptureStatus::kTimeout;
    return c;
  }
  if (rc < 0) {
    ++stats_.disconnects;
    c.status = rc == -ENODEV || rc == -EIO || rc == -ENXIO ? CaptureStatus::kDisconnected : CaptureStatus::kError;
    c.error = std::string("v4l2 ") + cfg_.device + ": " + std::strerror(-rc);
    return c;
  }
  const auto now = clock_pair_now();  // one instant: a preemption between two reads would shift the frame's stamp
  const Nanos real = now.vehicle_ns;
  const Nanos mono = now.monotonic_ns;
  count_sequence(b.sequence);
  if (b.index >= buffers_.size() || (b.flags & V4L2_BUF_FLAG_ERROR) != 0 || b.bytesused < image_bytes_) {
    ++stats_.incomplete;
    ++stats_.incomplete_other;
    c.status = CaptureStatus::kIncomplete;
    c.error = "short or damaged buffer: " + std::to_string(b.bytesused) + " of " + std::to_string(image_bytes_) + " bytes";
    requeue(b.index);
    return c;
  }
  FrameMeta m;
  m.seq = b.sequence;
  m.width = cfg_.width;
  m.height = cfg_.height;
  m.step = step_;
  m.format = cfg_.format;
  m.domain = TimeDomain::kMonotonic;
  // An end-of-frame stamp: the exposure started exposure + readout earlier (not a whole period).
  bool eof = cfg_.v4l2_stamp == "end" ||
             (cfg_.v4l2_stamp == "auto" && (b.flags & V4L2_BUF_FLAG_TSTAMP_SRC_MASK) == V4L2_BUF_FLAG_TSTAMP_SRC_EOF);
  const Nanos stamp = buffer_stamp_mono(b, real, mono, eof);
  m.device_ns = stamp;
  if (eof) m.device_ns -= eof_offset_ns();
  m.first_rx_ns = real - (mono - stamp);
  m.complete_ns = real;
  m.complete_mono_ns = mono;
  ++stats_.completed;
  const std::uint32_t index = b.index;
  c.status = CaptureStatus::kFrame;
  c.frame = Frame(m, {static_cast<std::uint8_t*>(buffers_[index].addr), image_bytes_}, [this, index] { requeue(index); });
  return c;
}

}  // namespace sensor_rig::camera
