#include "sensor_rig/drivers/camera/camera_driver.hpp"

#include <pthread.h>

#include <cstdlib>
#include <cstring>
#include <mutex>
#include <thread>

#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/realtime_thread.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/dds/publish_stats.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/drivers/camera/frame_clock.hpp"
#include "sensor_rig/drivers/camera/publish_queue.hpp"
#include "sensor_rig/timesync/host_clock.hpp"
#include "image_outputs.hpp"

namespace sensor_rig::drivers {
namespace {

// Reopen attempts back off exponentially from the first to the cap: a dead camera costs a few
// GVCP timeouts every 2 s, and a camera that comes back streams again well within the 5 s the
// campaign allows (its open is ~0.1-0.3 s). Reset by a successful open.
constexpr Nanos kReopenFirstNs = 250'000'000;
constexpr Nanos kReopenMaxNs = 2'000'000'000;
// A V4L2 device that is not there fails its open at once (ENODEV, no network timeout): retried at
// the first step, so a USB camera plugged back streams within a quarter second, not up to 2 s
// (the campaign's v4l2.disconnect: back at its end, streaming 1.8 s later).
constexpr Nanos kReopenMaxV4l2Ns = kReopenFirstNs;
// A device stamp rejected this recently flags the topic unsynchronized in /diagnostics.
constexpr Nanos kUnsyncHoldNs = 2'000'000'000;
// Frames between capture and their write: one being written, this many waiting (a slow subscriber
// costs these frames, counted, not the capture thread's time). Each holds a source buffer.
constexpr std::size_t kPublishQueueDepth = 2;

// What a rejected device stamp's error suggests: TAI taken as UTC or the other way round is a
// wrong `timescale` (detected, not applied), anything else a clock that is not the PU's.
std::string stamp_fix(Nanos error_ns, const camera::PtpConfig& ptp) {
  const Nanos tai_utc = static_cast<Nanos>(ptp.tai_utc_offset_s > 0 ? ptp.tai_utc_offset_s : 37) * 1'000'000'000;
  const auto near = [&](Nanos v) { return std::llabs(error_ns - v) < 1'000'000'000; };
  if (ptp.enable && (near(tai_utc) || near(-tai_utc)))
    return std::string("off by TAI - UTC: ptp timescale is ") + (ptp.tai ? "tai" : "utc") + ", the camera's is not";
  return "host arrival time used";
}

}  // namespace

struct CameraDriver::Impl {
  // A captured frame, stamped, on its way to the publishing thread.
  struct PublishJob {
    camera::Frame frame;
    FrameStamp stamp;
    Nanos ready_ns = 0;  // when the capture thread had it
  };

  CameraConfig cfg;
  std::string image_topic_name;
  std::string info_topic_name;
  // Shared with the trigger's call: a call in flight that the trigger source left (a camera that
  // died in a GVCP write) keeps the source alive until it returns (issue 27 item 1).
  std::shared_ptr<camera::FrameSource> src;
  dds::Topic<msg::Image> image_topic;
  dds::Writer<msg::Image> image_writer;
  dds::Topic<msg::CameraInfo> info_topic;
  dds::Writer<msg::CameraInfo> info_writer;
  dds::StampsWriter& stamps;
  TriggerSource* trigger;
  std::size_t trigger_member = 0;  // this camera's index in its trigger's members
  FrameClock clock;
  std::vector<double> d;  // CameraInfo.d storage
  std::unique_ptr<ImageOutputs> outputs;  // image_color / compressed on their own thread; null: none
  std::thread thread;
  std::atomic<bool> stop_flag{false};
  // Captured frames to their writes; held frames hold source buffers: drained before every close.
  PublishQueue<PublishJob> publisher;
  std::uint64_t queue_dropped_reported = 0;  // the publishing thread's: drops told in SampleStamps

  mutable std::mutex mutex;  // counters shared with status(); written by the driver thread
  dds::PublishStats published;  // image_raw: frames, rate, write failures
  std::uint64_t reopens = 0;
  std::uint64_t lost_reports = 0;
  std::uint64_t incomplete_since_publish = 0;
  Nanos last_frame_host_ns = 0;
  Nanos last_frame_mono_ns = 0;  // the watchdog's clock: a CLOCK_REALTIME step neither trips nor blinds it
  bool open = false;
  std::string state = "opening";
  std::string last_error;
  StampSource stamp_source = StampSource::kHostFallback;
  camera::SourceStats source_stats;
  camera::PtpState ptp;
  timesync::ClockMapperStatus sync;
  timesync::MonotonicStampsStatus monotonic;
  FrameClock::Rejected rejected;   // device stamps outside the arrival window
  Nanos rejected_seen_mono_ns = 0; // when the count last grew (CLOCK_MONOTONIC)
  Nanos slewed_seen_mono_ns = 0;   // when a stamp last carried a step back's correction (FrameStamp::slewed)
  Nanos unlocked_seen_mono_ns = 0; // when a stamp last came from device ticks not mapped (locked) yet
  Nanos doubtful_seen_mono_ns = 0; // when a stamp last was FrameStamp::doubtful (arrivals late against the camera's clock)
  Nanos doubtful_shift_ns = 0;     // by how much they were late then
  std::uint64_t doubtful_frames = 0;  // frames stamped so (status `stamp_doubtful`)
  Nanos floor_unseen_mono_ns = 0;  // when a stamp last was FrameStamp::floor_unseen (the mapping's floor seen too rarely)
  std::uint64_t floor_unseen_frames = 0;
  timesync::ClockMapper::FloorSupport floor{};  // the mapping's floor support at the last frame
  timesync::RealtimeStepDetector realtime_steps;  // told to the clock: stamps held over a step back

  Impl(const CameraConfig& c, std::unique_ptr<camera::FrameSource> s, const dds::Participant& p, dds::StampsWriter& st,
       TriggerSource* t)
      : cfg(c),
        image_topic_name("/sensors/camera/" + c.name + "/image_raw"),
        info_topic_name("/sensors/camera/" + c.name + "/camera_info"),
        src(std::move(s)),
        image_topic(p, image_topic_name, c.qos),
        image_writer(p, image_topic, c.qos),
        info_topic(p, info_topic_name, c.qos),
        info_writer(p, info_topic, c.qos),
        stamps(st),
        trigger(t),
        clock(static_cast<Nanos>(c.source.exposure_us * 1000.0)),
        d(c.info.d),
        outputs(c.outputs.any() ? std::make_unique<ImageOutputs>(c, p, st) : nullptr),
        publisher(("pub:" + c.name).substr(0, 15), kPublishQueueDepth, [this](PublishJob& j) { publish(j); }) {}

  msg::CameraInfo camera_info(const msg::Time& stamp) {
    msg::CameraInfo ci{};
    ci.header.stamp = stamp;
    ci.header.frame_id = const_cast<char*>(cfg.frame_id.c_str());
    ci.height = cfg.source.height;
    ci.width = cfg.source.width;
    ci.distortion_model = const_cast<char*>(cfg.info.distortion_model.c_str());
    ci.d._buffer = d.data();
    ci.d._length = ci.d._maximum = static_cast<std::uint32_t>(d.size());
    std::copy(cfg.info.k.begin(), cfg.info.k.end(), ci.k);
    std::copy(cfg.info.r.begin(), cfg.info.r.end(), ci.r);
    std::copy(cfg.info.p.begin(), cfg.info.p.end(), ci.p);
    ci.roi.width = 0;  // full image (ROS: all zero = full resolution)
    return ci;
  }

  // On the capture thread: the stamp (the clock and the trigger matching keep frame order), then
  // the hand-off; the write is the publishing thread's (issue 27 item 13: a slow reliable
  // subscriber blocked the capture thread up to 50 ms a frame).
  void capture(camera::Frame& f) {
    const Nanos ready = vehicle_now_ns();
    const auto& m = f.meta();
    const Nanos tick = trigger != nullptr ? trigger->tick_before(clock.trigger_reference(m), trigger_member) : 0;
    const auto st = clock.stamp(m, tick);
    // The camera's own exposure start of a triggered frame: the trigger's phase figure includes
    // the camera's trigger -> exposure delay where the device reports it.
    if (tick > 0 && st.device_exposure_ns > 0) trigger->exposed(trigger_member, tick, st.device_exposure_ns);
    {
      std::lock_guard lock(mutex);
      if (st.slewed) slewed_seen_mono_ns = monotonic_now_ns();
      if (st.doubtful) {
        doubtful_seen_mono_ns = monotonic_now_ns();
        doubtful_shift_ns = clock.late_shift_ns();
        ++doubtful_frames;
      }
      if (st.floor_unseen) {
        floor_unseen_mono_ns = monotonic_now_ns();
        ++floor_unseen_frames;
      }
      floor = clock.floor();
      // A device-tick camera stamped before its clock mapping locked (after every open): the stamp
      // is the arrival less the exposure, or a line of a few arrivals, or the trigger's tick, off
      // by the transport and host delay it cannot see (10-minute campaign: corner_front_right 1.8-
      // 2.2 ms off for five frames, a stereo frame 2.5 ms, after reopens): flagged, not passed as
      // the device's time.
      const bool from_ticks = st.source == StampSource::kDeviceMapped || st.source == StampSource::kHostFallback ||
                              st.source == StampSource::kTriggerTick;
      if (from_ticks && st.device_exposure_ns == 0) unlocked_seen_mono_ns = monotonic_now_ns();
      stamp_source = st.source;
      last_frame_host_ns = ready;
      last_frame_mono_ns = monotonic_now_ns();  // the watchdog watches the device, not the writer
    }
    publisher.push(PublishJob{std::move(f), st, ready});
  }

  void publish(PublishJob& job) {
    const camera::Frame& f = job.frame;
    const auto& st = job.stamp;
    const auto& m = f.meta();
    msg::Image img{};
    img.header.stamp = msg::to_time(st.vehicle_ns);
    img.header.frame_id = const_cast<char*>(cfg.frame_id.c_str());
    img.height = m.height;
    img.width = m.width;
    img.encoding = const_cast<char*>(camera::info(m.format).ros_encoding);
    img.is_bigendian = 0;
    img.step = m.step;
    // The source's buffer is the published buffer: no copy between capture and the writer.
    img.data._buffer = f.data().data();
    img.data._length = img.data._maximum = static_cast<std::uint32_t>(f.data().size());
    img.data._release = false;
    const Nanos publish = vehicle_now_ns();
    const auto rc = image_writer.write(img, publish);
    const Nanos written = vehicle_now_ns();
    const auto ci = camera_info(img.header.stamp);
    (void)info_writer.write(ci, publish);
    std::uint64_t dropped = 0;
    {
      std::lock_guard lock(mutex);
      dropped = incomplete_since_publish;
      incomplete_since_publish = 0;
    }
    // Frames the queue dropped since the last published one: lost between capture and the writer.
    const std::uint64_t queue_dropped = publisher.dropped();
    dropped += queue_dropped - queue_dropped_reported;
    queue_dropped_reported = queue_dropped;
    dds::SampleStamps s{st.vehicle_ns, m.first_rx_ns, m.complete_ns, job.ready_ns, publish, written,
                        m.packets, static_cast<std::uint32_t>(dropped), img.data._length};
    stamps.write(image_topic_name, img.header.stamp, img.header.frame_id, m.seq, s);
    // A copy into the worker's queue (never waits for the worker); the raw frame is already out.
    if (outputs) outputs->offer(m, st.vehicle_ns, f.data());
    std::lock_guard lock(mutex);
    if (!published.count(rc, publish)) last_error = "dds write: " + rc.message();
  }

  void set_state(const std::string& s, const std::string& err = {}) {
    std::lock_guard lock(mutex);
    state = s;
    if (!err.empty()) last_error = err;
  }

  bool try_open() {
    try {
      src->open();
      // A reopened device may restart its tick counter. Exposure: what the device reports it uses
      // after every feature was applied (issue 27 item 9), else the config's.
      const double exposure_us = src->exposure_us() > 0 ? src->exposure_us() : cfg.source.exposure_us;
      clock.reset(static_cast<Nanos>(exposure_us * 1000.0));
      std::lock_guard lock(mutex);
      open = true;
      state = "streaming";
      const auto now = clock_pair_now();  // the watchdog starts now
      last_frame_host_ns = now.vehicle_ns;
      last_frame_mono_ns = now.monotonic_ns;
      return true;
    } catch (const std::exception& e) {
      set_state("opening", e.what());
      return false;
    }
  }

  void lose(const std::string& why) {
    src->mark_lost();
    publisher.drain();  // the queued frames hold the source's buffers
    src->close();
    log::warn("camera", cfg.name + ": " + why + "; reopening");
    std::lock_guard lock(mutex);
    open = false;
    ++lost_reports;
    state = "lost";
    last_error = why;
  }

  void run() {
    Nanos next_open = 0;
    Nanos backoff = kReopenFirstNs;
    bool was_open = false;
    while (!stop_flag.load() && !shutdown_requested()) {
      if (!src->is_open()) {
        const Nanos now = monotonic_now_ns();
        if (now < next_open) {
          ::usleep(20'000);
          continue;
        }
        if (!try_open()) {
          next_open = monotonic_now_ns() + backoff;
          backoff = std::min(backoff * 2, cfg.source.backend == "v4l2" ? kReopenMaxV4l2Ns : kReopenMaxNs);
          continue;
        }
        backoff = kReopenFirstNs;
        if (was_open) {
          std::lock_guard lock(mutex);
          ++reopens;
        }
        was_open = true;
        log::info("camera", cfg.name + ": streaming " + src->describe());
      }
      auto c = src->next(50);
      switch (c.status) {
        case camera::CaptureStatus::kFrame:
          // Before the stamp: a step before this frame's dequeue is known when it is mapped.
          if (const auto now = clock_pair_now(); true) clock.realtime_step(realtime_steps.observe(now.vehicle_ns, now.monotonic_ns));
          capture(c.frame);
          break;
        case camera::CaptureStatus::kIncomplete: {
          // The camera is sending (a lossy link drops packets): not the silence the watchdog is
          // for. Reopening it under 1 % packet loss did not bring a frame more (issue 27).
          std::lock_guard lock(mutex);
          ++incomplete_since_publish;
          last_frame_mono_ns = monotonic_now_ns();
          break;
        }
        case camera::CaptureStatus::kDisconnected:
          lose(c.error.empty() ? "disconnected" : c.error);
          break;
        case camera::CaptureStatus::kError:
          set_state("streaming", c.error);
          break;
        case camera::CaptureStatus::kTimeout:
          break;
      }
      c.frame.reset();  // the buffer goes back to the source before it is used again
      Nanos last = 0;
      {
        std::lock_guard lock(mutex);
        last = last_frame_mono_ns;
      }
      const Nanos now = monotonic_now_ns();
      const Nanos watchdog = static_cast<Nanos>(cfg.watchdog()) * 1'000'000;
      if (src->is_open() && now - last > watchdog) {
        // A triggered camera is silent for a reason only once it took a trigger: watched from the
        // first one after its last frame. Without one (a stopped LIDAR, a sweep not predicted yet)
        // it is not at fault and a reopen would not bring frames (issue 27 item 2: 29 reopens in
        // 15 s; a reopen while the sweep locked lost sync_sets_test's first trigger). Reported.
        const Nanos since = trigger != nullptr ? trigger->first_accepted_since(trigger_member, last) : last;
        if (since == 0)
          set_state("not triggered");
        else if (now - since > watchdog)
          lose("no frame for " + std::to_string((now - last) / 1'000'000) + " ms");
      } else if (trigger != nullptr) {
        std::lock_guard lock(mutex);
        if (state == "not triggered") state = "streaming";
      }
      std::lock_guard lock(mutex);
      source_stats = src->stats();
      if (cfg.source.ptp.enable) ptp = src->ptp();
      sync = clock.status(vehicle_now_ns());
      monotonic = clock.monotonic();
      if (clock.rejected().count != rejected.count) rejected_seen_mono_ns = monotonic_now_ns();
      rejected = clock.rejected();
    }
    publisher.drain();
    src->close();
    // What the close counted (frames filled and never dequeued, frames the device began after the
    // last dequeue): status() and the stop's line read these, not the source.
    std::lock_guard lock(mutex);
    source_stats = src->stats();
  }
};

CameraDriver::CameraDriver(const CameraConfig& cfg, const dds::Participant& participant, dds::StampsWriter& stamps,
                           TriggerSource* trigger)
    : CameraDriver(cfg, make_camera_source(cfg), participant, stamps, trigger) {}

CameraDriver::CameraDriver(const CameraConfig& cfg, std::unique_ptr<camera::FrameSource> source,
                           const dds::Participant& participant, dds::StampsWriter& stamps, TriggerSource* trigger)
    : impl_(std::make_unique<Impl>(cfg, std::move(source), participant, stamps, trigger)) {
  if (trigger != nullptr)
    impl_->trigger_member = trigger->add([src = std::weak_ptr<camera::FrameSource>(impl_->src)] {
      const auto s = src.lock();
      return s && s->trigger();
    });
}

CameraDriver::~CameraDriver() { stop(); }

camera::FrameSource& CameraDriver::source() { return *impl_->src; }
std::string CameraDriver::topic() const { return impl_->image_topic_name; }

void CameraDriver::start() {
  if (impl_->outputs) impl_->outputs->start();
  impl_->publisher.start();
  make_realtime(impl_->publisher.thread(), impl_->cfg.realtime_priority, "camera publisher " + impl_->cfg.name);
  impl_->thread = std::thread([this] { impl_->run(); });
  (void)pthread_setname_np(impl_->thread.native_handle(), ("cam:" + impl_->cfg.name).substr(0, 15).c_str());
  make_realtime(impl_->thread, impl_->cfg.realtime_priority, "camera " + impl_->cfg.name);
  log::info("camera", impl_->cfg.name + ": " + impl_->src->describe() + " -> " + impl_->image_topic_name);
}

void CameraDriver::request_stop() noexcept { impl_->stop_flag.store(true); }

void CameraDriver::stop() {
  impl_->stop_flag.store(true);
  if (!impl_->thread.joinable()) return;
  impl_->thread.join();
  impl_->publisher.stop();
  if (impl_->outputs) impl_->outputs->stop();
  const auto st = status();
  std::string line = impl_->cfg.name + ":";
  for (const auto& [k, v] : st.values)
    if (k == "frames" || k == "incomplete" || k == "reopens" || k == "stamp_source" || k == "sync" || k == "triggers" ||
        k == "stamp_rejected" || k == "stamp_doubtful" ||
        k.rfind("phase_", 0) == 0 || k.rfind("trigger_spread_", 0) == 0 || k.rfind("trigger_call_", 0) == 0 ||
        k.rfind("trigger_to_exposure_", 0) == 0)
      line.append(" ").append(k).append("=").append(v);
  log::info("camera", line);
}

dds::DriverStatus CameraDriver::status() const {
  const auto& c = impl_->cfg;
  std::lock_guard lock(impl_->mutex);
  dds::DriverStatus s;
  s.name = "camera/" + c.name;
  s.hardware_id = std::string(c.source.backend) + ":" + c.source.device;
  const Nanos age = impl_->last_frame_mono_ns == 0 ? -1 : monotonic_now_ns() - impl_->last_frame_mono_ns;
  const auto recent = [](Nanos seen) { return seen != 0 && monotonic_now_ns() - seen < kUnsyncHoldNs; };
  const bool rejected_recently = recent(impl_->rejected_seen_mono_ns);
  // Stamps held and slewed after a CLOCK_REALTIME step back are later than vehicle time by up to the
  // step for ten times its length (timesync/README.md "Realtime steps"): flagged, not passed as exact.
  const bool slewed_recently = recent(impl_->slewed_seen_mono_ns);
  const bool unlocked_recently = recent(impl_->unlocked_seen_mono_ns);
  // Frames arriving later than the camera's clock says, for longer than a host hiccup: a held network
  // (the stamps are the exposures) or the camera's clock stepped back (they are the step off); not
  // told apart for 3 s (timesync/README.md item 5): flagged, as the LIDARs' are.
  const bool doubtful_recently = recent(impl_->doubtful_seen_mono_ns);
  // The mapping rests on a floor few recent frames saw: the receiving thread is held off most
  // frames, and the line may be late by that (FrameStamp::floor_unseen).
  const bool floor_unseen_recently = recent(impl_->floor_unseen_mono_ns);
  const bool unsynchronized =
      rejected_recently || slewed_recently || unlocked_recently || doubtful_recently || floor_unseen_recently;
  if (!impl_->open) {
    s.level = impl_->published.samples() == 0 && impl_->lost_reports == 0 ? dds::Level::kWarn : dds::Level::kError;
    s.message = impl_->state + (impl_->last_error.empty() ? "" : ": " + impl_->last_error);
  } else if (impl_->state == "not triggered") {
    s.level = dds::Level::kWarn;
    s.message = "not triggered: its trigger source fired no shot the camera took";
  } else if (impl_->published.samples() == 0 && age > 1'000'000'000) {
    s.level = dds::Level::kWarn;
    s.message = "waiting for frames";
  } else if (age > static_cast<Nanos>(c.watchdog()) * 1'000'000) {
    s.level = dds::Level::kError;
    s.message = "no frame for " + std::to_string(age / 1'000'000) + " ms";
  } else if (slewed_recently && !rejected_recently) {
    s.level = dds::Level::kWarn;
    s.message = "unsynchronized: stamps slewed after a CLOCK_REALTIME step back (" +
                std::to_string(impl_->monotonic.correction_ns / 1'000'000) + " ms still added)";
  } else if (doubtful_recently && !rejected_recently) {
    s.level = dds::Level::kWarn;
    s.message = "unsynchronized: frames arrive " + std::to_string(impl_->doubtful_shift_ns / 1'000'000) +
                " ms later than the camera's clock says (a held network, or its clock stepped back: stamps from its clock)";
  } else if (floor_unseen_recently && !rejected_recently && !unlocked_recently) {
    s.level = dds::Level::kWarn;
    s.message = "unsynchronized: only " + std::to_string(impl_->floor.seen) + " of the last " + std::to_string(impl_->floor.of) +
                " device clock buckets had a prompt frame (the receiving thread is held off: give the camera realtime_priority)";
  } else if (unlocked_recently && !rejected_recently) {
    s.level = dds::Level::kWarn;
    s.message = "unsynchronized: the device clock is not mapped yet (stamps from the arrival or the trigger)";
  } else if (unsynchronized) {
    // Device stamps outside the arrival window were replaced: the topic's stamps are not the
    // camera's clock right now (issue 27 item 7).
    s.level = dds::Level::kWarn;
    s.message = "unsynchronized: device stamps " + std::to_string(impl_->rejected.last_error_ns / 1'000'000) +
                " ms off the arrival replaced (" + stamp_fix(impl_->rejected.last_error_ns, c.source.ptp) + ")";
  } else {
    s.message = "running";
  }
  const auto& st = impl_->source_stats;
  s.add("topic", impl_->image_topic_name);
  s.add("state", impl_->state);
  s.add_number("frames", impl_->published.samples());
  s.add("frame_rate_hz", std::to_string(impl_->published.rate_hz()));
  s.add_number("incomplete", st.incomplete);
  // Frames the camera made that never reached the rig (id / sequence gaps), and every frame made and
  // not published: the cumulative count `rig monitor` and `rig chaos` read (issue 27 item 5).
  s.add_number("missing_frames", st.missing_frames);
  // Frames dropped between capture and the writer (a writer slower than the camera) are in it too.
  const std::uint64_t publish_dropped = impl_->publisher.dropped();
  s.add_number("counted_lost", st.lost_frames() + publish_dropped);
  s.add_number("publish_dropped", publish_dropped);
  // Where incomplete frames went, by the stream's buffer status (rig monitor: drops by stage).
  s.add_number("incomplete_timeout", st.incomplete_timeout);
  s.add_number("incomplete_missing_packets", st.incomplete_missing_packets);
  s.add_number("incomplete_other", st.incomplete_other);
  s.add_number("timeouts", st.timeouts);
  s.add_number("underruns", st.underruns);
  s.add_number("trigger_busy", st.trigger_busy);
  s.add_number("missing_packets", st.missing_packets);
  if (st.socket_buffer_granted > 0) {  // GigE: the kernel's grant against one frame (issue 27 item 4)
    s.add_number("socket_buffer_granted", st.socket_buffer_granted);
    s.add_number("socket_buffer_needed", st.socket_buffer_needed);
    if (st.socket_buffer_granted < st.socket_buffer_needed)
      s.add("socket_buffer", "too small for a frame: net.core.rmem_max or socket_buffer_bytes (the WARN at open says which)");
  }
  s.add_number("resent_packets", st.resent_packets);
  if (st.payload != nullptr && *st.payload != '\0') s.add("gvsp_payload", st.payload);  // what the camera sends
  s.add_number("lost_reports", impl_->lost_reports);
  s.add_number("reopens", impl_->reopens);
  s.add_number("write_errors", impl_->published.write_errors());
  s.add("trigger", camera::to_string(c.source.trigger));
  s.add("stamp_source", to_string(impl_->stamp_source));
  s.add("sync", timesync::to_string(impl_->sync.state));
  s.add_number("sync_offset_ns", impl_->sync.offset_ns);
  s.add("sync_drift_ppm", std::to_string(impl_->sync.drift_ppm));
  s.add_number("sync_residual_p99_ns", impl_->sync.residual_p99_ns);
  if (!c.source.ptp.enable) {
    s.add("ptp", "not used (device ticks mapped)");
  } else {
    // The device's PTP state; stamps are PTP time (device_vehicle) only while it is locked.
    const auto& p = impl_->ptp;
    s.add("ptp", !p.enabled ? "not enabled (device not open)"
                 : p.locked ? "locked (" + p.status + ", " + (c.source.ptp.tai ? "TAI -> UTC" : "UTC") + ")"
                            : "not locked (" + p.status + "): device ticks mapped");
    s.add("ptp_status", p.status);
    s.add_number("ptp_resets", p.resets);
    s.add_number("ptp_polls", p.polls);
    s.add_number("ptp_poll_max_us", p.poll_max_us);
    if (!p.error.empty()) s.add("ptp_error", p.error);
  }
  // CLOCK_REALTIME stepped back: stamps held and slewed (timesync/README.md "Realtime steps").
  s.add_number("stamp_backward_steps", impl_->monotonic.backward_steps);
  s.add_number("stamp_correction_ns", impl_->monotonic.correction_ns);
  s.add_number("stamp_device_backward", impl_->monotonic.device_backward);
  s.add("stamp_sync", unsynchronized ? "unsynchronized" : "ok");
  s.add_number("stamp_rejected", impl_->rejected.count);
  // Of them: replaced while the mapper held a device clock step it had not confirmed (issue 27 item 8).
  s.add_number("stamp_rejected_steps", impl_->rejected.steps);
  // Frames stamped from the camera's clock while they arrived later than it says (FrameStamp::doubtful).
  s.add_number("stamp_doubtful", impl_->doubtful_frames);
  // Frames stamped from a mapping whose floor too few recent frames saw, and the support now.
  s.add_number("stamp_floor_unseen", impl_->floor_unseen_frames);
  s.add_number("sync_floor_seen", impl_->floor.seen);
  s.add_number("sync_floor_of", impl_->floor.of);
  s.add_number("sync_jumps", impl_->sync.jumps);
  if (!impl_->last_error.empty()) s.add("last_error", impl_->last_error);
  if (impl_->outputs) impl_->outputs->add_status(s);
  if (impl_->trigger != nullptr) impl_->trigger->add_status(s, impl_->trigger_member);
  return s;
}

}  // namespace sensor_rig::drivers
