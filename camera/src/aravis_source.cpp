// AravisSource: capture (next, stats), triggers and feature access. The connection (open,
// configuration, reopen, close) is in aravis_open.cpp, the PTP state in aravis_ptp.cpp.
#include "sensor_rig/camera/aravis_source.hpp"

#include <arv.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>

#include "aravis_internal.hpp"
#include "exposure_watcher.hpp"
#include "gvsp_payload.hpp"

namespace sensor_rig::camera {
namespace {

// How long trigger() waits for the camera's locks (see trigger()).
constexpr int kTriggerLockWaitMs = 5;

}  // namespace

using detail::take_error;

AravisSource::AravisSource(SourceConfig cfg, AravisDeviceOpener opener)
    : cfg_(std::move(cfg)), opener_(std::move(opener)), st_(std::make_unique<State>()) {
  if (!opener_) {  // the network: a device given as an address is probed first, without a lock (open())
    network_ = true;
    opener_ = open_aravis_network_device;
  }
  if (!backend_supports("aravis", cfg_.format))
    throw CameraError("aravis " + cfg_.device + ": pixel format not supported (supported: " + pixel_format_names("aravis") + ")");
}

AravisSource::~AravisSource() { close(); }

// Lock-free: the capture loop asks every turn, and must not queue behind a trigger's GVCP call on
// a camera that stopped answering (its watchdog would never run).
bool AravisSource::is_open() const noexcept { return open_.load(); }

std::string AravisSource::describe() const {
  return "aravis " + cfg_.device + " " + info(cfg_.format).genicam + " " + std::to_string(cfg_.width) + "x" +
         std::to_string(cfg_.height) + "@" + std::to_string(cfg_.frame_rate) + " trigger " + to_string(cfg_.trigger);
}

double AravisSource::exposure_us() const {
  if (const Nanos ns = last_exposure_ns_.load(); ns > 0) return static_cast<double>(ns) / 1000.0;
  return details().exposure_us;
}

AravisDetails AravisSource::details() const {
  std::lock_guard lock(mutex_);
  return details_;
}
void AravisSource::set_feature(const std::string& name, const std::string& value) {
  std::lock_guard lock(mutex_);
  std::lock_guard gl(*gc_mutex_);
  if (st_->device == nullptr) throw CameraError("aravis " + cfg_.device + ": not open");
  const std::string assignment = name + "=" + value;
  GError* err = nullptr;
  arv_device_set_features_from_string(st_->device, assignment.c_str(), &err);
  if (err != nullptr) throw CameraError("aravis " + cfg_.device + ": feature " + assignment + ": " + take_error(err));
}
std::string AravisSource::feature(const std::string& name) const {
  std::lock_guard lock(mutex_);
  std::lock_guard gl(*gc_mutex_);
  if (st_->device == nullptr) return {};
  ArvGcNode* node = arv_device_get_feature(st_->device, name.c_str());
  if (node == nullptr || !ARV_IS_GC_FEATURE_NODE(node)) return {};
  GError* err = nullptr;
  const char* v = arv_gc_feature_node_get_value_as_string(reinterpret_cast<ArvGcFeatureNode*>(node), &err);
  if (err != nullptr) {
    g_error_free(err);
    return {};
  }
  return v != nullptr ? v : "";
}

bool AravisSource::trigger() {
  if (cfg_.trigger != TriggerMode::kSoftware) return false;  // free run or a line: nothing to send
  // Not streaming (opening, closing, lost): refused at once; the locks below are never held
  // across another thread's open, so a trigger waits at most for a GenICam access in flight.
  if (!streaming_.load() || control_lost_.load()) return false;
  // A trigger never waits behind another GenICam access in a GVCP timeout (the exposure read or
  // the PTP poll on a camera that stopped answering, a close's stop): a healthy access is well
  // under a millisecond (measured: no trigger waited > 0.2 ms in 340 calls beside the per-frame
  // exposure read, sync_sets_test under load), so a longer one means the shot is lost anyway.
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(kTriggerLockWaitMs);
  ArvCamera* camera = nullptr;
  std::shared_ptr<std::timed_mutex> gc;  // this connection's GenICam lock (open() installs a new one)
  {
    std::unique_lock lock(mutex_, until);
    if (!lock.owns_lock()) {
      trigger_lock_busy_.fetch_add(1);
      return false;
    }
    if (st_->camera == nullptr || control_lost_.load()) return false;
    gc = gc_mutex_;
    if (!gc->try_lock_until(until)) {
      trigger_lock_busy_.fetch_add(1);
      return false;
    }
    camera = static_cast<ArvCamera*>(g_object_ref(st_->camera));
  }
  // The GVCP write runs without mutex_ and touches nothing of this source: on a camera that died
  // Aravis retries it ~2.4 s, and neither close() nor the trigger source's stop waits for that
  // (issue 27 item 1). The camera reference keeps the connection alive for the call; close()
  // takes the GenICam lock before it talks to a camera that still answers.
  GError* err = nullptr;
  arv_camera_software_trigger(camera, &err);
  g_object_unref(camera);
  gc->unlock();
  if (err == nullptr) return true;
  g_error_free(err);
  return false;
}

// GigE Vision 1.x block ids run 1..65535 and wrap to 1 (0 is reserved): a step of more than one
// is frames the camera made that never came out of the stream (an underrun, a frame Aravis dropped).
// The ids are kept across a close and an open: a camera that was only closed and opened again (the
// watchdog's reopen, a clean close) goes on numbering, and the frames it made meanwhile (waiting in
// the closed stream, sent to it until the camera was stopped again) are a gap like any other; the
// count restarted with each open and missed them (issue 27: "an uncounted first frame after a
// reopen"). A camera that restarted (power cycle: ids from 1 again, its tick counter from 0) shows
// a step back, a jump more frames than its rate allows in the time since its last frame, or device
// ticks that did not follow that time: no loss known, counting starts again.
//
// An incomplete buffer's id may not be its frame's: Aravis (0.8) sets a buffer's frame id and
// timestamp from the GVSP leader only, so a frame whose leader was lost comes out with the id of
// the frame the buffer held before (0 for a buffer not used yet), a few frames back. Taken as the
// newest id, the next frame's id "jumped" by the stream's depth: every lost leader counted its
// frame lost twice and the 3 frames after it once more (4 buffers; issue 27, "58 counted lost, 50
// not published" under camera.packet_loss). Such an id (0, or not ahead of the last known one) is
// not used: the frame is counted where it is counted (incomplete, undelivered), and the next known
// id's step counts only the frames beyond those. A leaderless buffer is never complete (Aravis
// completes a frame from packet 0 on), so complete buffers' ids are always their own.
void AravisSource::count_missing_frames(std::uint64_t id, Nanos device_ns, Nanos mono_ns, bool complete) noexcept {
  constexpr std::int64_t kWrap = 65535;
  constexpr std::int64_t kPlausibleGap = 1000;
  std::int64_t d = static_cast<std::int64_t>(id) - static_cast<std::int64_t>(last_frame_id_);
  if (id <= 0xFFFF && last_frame_id_ <= 0xFFFF && d <= 0) d += kWrap;
  if (!complete && (id == 0 || (last_frame_id_ != 0 && (d <= 0 || d > kPlausibleGap)))) {
    ++unknown_id_frames_;
    return;
  }
  if (last_frame_id_ != 0 && id != 0) {
    std::int64_t most = kPlausibleGap;
    if (reopened_) {
      // What the camera can have made since its last frame, at its rate (a triggered camera's is
      // the trigger's) with a margin; its clock must have run that time too (a reboot restarts it).
      const double elapsed_s = static_cast<double>(mono_ns - last_frame_mono_ns_) / 1e9;
      most = std::min<std::int64_t>(kPlausibleGap, static_cast<std::int64_t>(elapsed_s * std::max(cfg_.frame_rate, 1.0) * 1.5) + 2);
      const Nanos ticked = device_ns - last_frame_device_ns_;
      const Nanos elapsed = mono_ns - last_frame_mono_ns_;
      if (ticked < elapsed / 2 - 1'000'000'000 || ticked > elapsed * 2 + 1'000'000'000) most = 0;
    }
    const auto unknown = static_cast<std::int64_t>(unknown_id_frames_);
    if (d > 1 && d <= most && d - 1 > unknown) missing_frames_.fetch_add(static_cast<std::uint64_t>(d - 1 - unknown));
  }
  unknown_id_frames_ = 0;
  reopened_ = false;
  last_frame_id_ = id;
  last_frame_device_ns_ = device_ns;
  last_frame_mono_ns_ = mono_ns;
}

// At a close: the frames the stream holds that next() never returned (the consumer was behind)
// were made and are not published: counted lost, and their ids taken as seen, so that the gap at
// the next open counts only what came after them. A buffer without its own id (its leader lost:
// count_missing_frames) is a frame all the same.
void AravisSource::count_undelivered(ArvStream* stream) noexcept {
  if (stream == nullptr) return;
  const Nanos mono = monotonic_now_ns();
  while (ArvBuffer* b = arv_stream_try_pop_buffer(stream)) {
    count_missing_frames(arv_buffer_get_frame_id(b), static_cast<Nanos>(arv_buffer_get_timestamp(b)), mono,
                         arv_buffer_get_status(b) == ARV_BUFFER_STATUS_SUCCESS);
    missing_frames_.fetch_add(1);
    arv_stream_push_buffer(stream, b);  // the stream frees it with itself
  }
}

Capture AravisSource::next(int timeout_ms) {
  Capture c;
  ArvStream* stream = st_->stream;  // only this thread opens and closes
  if (stream == nullptr || control_lost_.load()) {
    if (stream != nullptr) ++disconnects_;
    c.status = CaptureStatus::kDisconnected;
    c.error = stream == nullptr ? "not open" : "aravis " + cfg_.device + ": control lost";
    return c;
  }
  ArvBuffer* b = arv_stream_timeout_pop_buffer(stream, static_cast<guint64>(timeout_ms) * 1000);
  if (b == nullptr) {
    ++timeouts_;
    c.status = control_lost_.load() ? CaptureStatus::kDisconnected : CaptureStatus::kTimeout;
    if (c.status == CaptureStatus::kDisconnected) c.error = "aravis " + cfg_.device + ": control lost";
    return c;
  }
  const auto now = clock_pair_now();  // one instant: a preemption between two reads would shift the frame's stamp
  const Nanos real = now.vehicle_ns;
  const Nanos mono = now.monotonic_ns;
  const auto status = arv_buffer_get_status(b);
  count_missing_frames(arv_buffer_get_frame_id(b), static_cast<Nanos>(arv_buffer_get_timestamp(b)), mono,
                       status == ARV_BUFFER_STATUS_SUCCESS);
  // Any payload type that carries the image (with chunks, chunk data, multipart), at its real
  // row stride (GVSP row padding): issue 27 items 3 and 13, gvsp_payload.hpp.
  const auto located = status == ARV_BUFFER_STATUS_SUCCESS ? detail::locate_image(b, cfg_.width, cfg_.height, cfg_.format)
                                                           : detail::LocatedImage{0, 0, "incomplete"};
  if (status != ARV_BUFFER_STATUS_SUCCESS || !located.error.empty()) {
    ++incomplete_;
    if (status == ARV_BUFFER_STATUS_TIMEOUT) ++incomplete_timeout_;
    else if (status == ARV_BUFFER_STATUS_MISSING_PACKETS) ++incomplete_missing_;
    else ++incomplete_other_;
    c.status = CaptureStatus::kIncomplete;
    c.error = "frame " + std::to_string(arv_buffer_get_frame_id(b)) + " status " + std::to_string(static_cast<int>(status)) +
              (status == ARV_BUFFER_STATUS_SUCCESS ? ": " + located.error : "");
    arv_stream_push_buffer(stream, b);
    return c;
  }
  const void* data = arv_buffer_get_data(b, nullptr);
  const auto index = static_cast<std::size_t>(reinterpret_cast<std::uintptr_t>(arv_buffer_get_user_data(b)));
  auto mem = st_->pool->buffer(index);
  const std::size_t want = std::size_t{located.step} * cfg_.height;
  if (data != mem.data() || located.offset + want > mem.size()) {  // not our memory or short: never publish it
    ++incomplete_;
    ++incomplete_other_;
    c.status = CaptureStatus::kIncomplete;
    c.error = "buffer of " + std::to_string(mem.size()) + " bytes, image of " + std::to_string(want) + " at " + std::to_string(located.offset);
    arv_stream_push_buffer(stream, b);
    return c;
  }
  payload_.store(detail::payload_name(b));
  FrameMeta m;
  m.seq = arv_buffer_get_frame_id(b);
  m.width = cfg_.width;
  m.height = cfg_.height;
  m.step = located.step;
  m.format = cfg_.format;
  m.device_ns = static_cast<Nanos>(arv_buffer_get_timestamp(b));
  m.device_ticks_ns = m.device_ns;
  m.domain = TimeDomain::kDeviceTicks;
  if (ptp_locked_.load(std::memory_order_relaxed)) {  // PTP time: TAI (or UTC) ns since 1970
    m.domain = TimeDomain::kVehicle;
    if (cfg_.ptp.tai) m.device_ns -= static_cast<Nanos>(cfg_.ptp.tai_utc_offset_s) * 1'000'000'000;
  }
  const auto sys = static_cast<Nanos>(arv_buffer_get_system_timestamp(b));
  m.first_rx_ns = sys > 0 && sys <= real ? sys : real;
  m.complete_ns = real;
  m.complete_mono_ns = mono;
  if (st_->payload > 0)  // GVSP data packets of this frame at the negotiated packet size
    m.packets = details_.packet_size > 36 ? static_cast<std::uint32_t>((want + static_cast<std::size_t>(details_.packet_size) - 37) /
                                                                       static_cast<std::size_t>(details_.packet_size - 36))
                                          : 0;
  const auto chunk = st_->chunks.read(st_->camera, b);  // none unless the buffer has chunks
  m.chunk_timestamp_ns = chunk.timestamp_ns;
  if (chunk.exposure_ns > 0) {  // this frame's own exposure: nothing to read over GVCP (issue 27 item 9)
    m.exposure_seq = m.seq;
    m.exposure_ns = chunk.exposure_ns;
    last_exposure_ns_.store(chunk.exposure_ns);
  } else if (exposure_) {  // the exposure of a frame before (read after it came), then ask for this one's
    const auto known = exposure_->known();
    m.exposure_seq = known.seq;
    m.exposure_ns = known.ns;
    if (known.ns > 0) last_exposure_ns_.store(known.ns);
    exposure_->want(m.seq);
  }
  ++completed_;
  c.status = CaptureStatus::kFrame;
  c.frame = Frame(m, mem.subspan(located.offset, want), [stream, b] { arv_stream_push_buffer(stream, b); });
  return c;
}

// The capture thread's (the one that opens and closes): no lock, so that a trigger in a GVCP
// timeout never holds the capture loop, and with it the watchdog, off.
SourceStats AravisSource::stats() const {
  SourceStats s = base_;
  if (st_->stream != nullptr) {
    guint64 completed = 0, failures = 0, underruns = 0;
    arv_stream_get_statistics(st_->stream, &completed, &failures, &underruns);
    s.underruns += underruns;
    if (st_->gv) {
      guint64 resent = 0, missing = 0;
      arv_gv_stream_get_statistics(reinterpret_cast<ArvGvStream*>(st_->stream), &resent, &missing);
      s.resent_packets += resent;
      s.missing_packets += missing;
    }
  }
  s.completed = completed_;
  s.incomplete = incomplete_;
  s.incomplete_timeout = incomplete_timeout_;
  s.incomplete_missing_packets = incomplete_missing_;
  s.incomplete_other = incomplete_other_;
  s.timeouts = timeouts_;
  s.disconnects = disconnects_;
  s.missing_frames = missing_frames_;
  s.trigger_busy = trigger_lock_busy_;
  s.socket_buffer_granted = socket_granted_.load();
  s.socket_buffer_needed = socket_needed_.load();
  s.payload = payload_.load();
  return s;
}

}  // namespace sensor_rig::camera
