#include "gige_fake_chaos.hpp"

#include <dlfcn.h>
#include <gio/gio.h>

#include <time.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cerrno>
#include <cstring>

#include "gvsp_format.hpp"
#include "sensor_rig/camera/mock/fake_cameras.hpp"

namespace sensor_rig::camera::mock {
namespace {

std::atomic<GigeFakeChaos*> g_chaos{nullptr};
constexpr guint16 kGvcpPort = 3956;
using gvsp::kLeader;
using gvsp::kTrailer;
constexpr double kSlowOpenLateS = 5;
constexpr Nanos kLeaderGapNs = 100'000;  // the leader goes out alone: its receiver takes it before the data  // the fake starts up to this long after the campaign's epoch

constexpr const char* kClock =
    "camera timestamp ns: the fake's CLOCK_REALTIME (UTC) at exposure start; with PtpEnable its PTP clock "
    "(Slave: TAI = UTC + 37 s; camera.ptp events: their state, tai_offset_s and step_ms)";

std::string detail_of(const faults::FaultEvent& e) {
  if (e.kind == "camera.packet_loss")
    return "p=" + e.text("p") + (e.number("resend") != 0 ? "; resend asked but not answered (the Aravis fake has no PACKETRESEND)" : "");
  if (e.kind == "camera.padded_rows")
    return "rows padded by " + e.text("bytes") + " bytes (GVSP x_padding, padding bytes 0xFF)";
  if (e.kind == "camera.chunk_data")
    return std::string("chunks ChunkTimestamp, ChunkExposureTime; payload type ") +
           (e.text("payload") == "chunk"       ? "0x0004 (chunk data, the image its first chunk)"
            : e.text("payload") == "multipart" ? "0x000A (multipart, extended ids: part 0 the chunks, part 1 the image)"
                                               : "0x4001 (image + chunks)");
  if (e.kind == "camera.ptp") return "state=" + e.text("state") + " tai_offset_s=" + e.text("tai_offset_s") + " step_ms=" + e.text("step_ms");
  if (e.kind == "camera.exposure_change") return "ExposureTimeAbs " + e.text("us") + " us";
  if (e.kind == "camera.slow_open") return "silent until " + e.text("s") + " s after the first GVCP request";
  if (e.kind.rfind("v4l2.", 0) == 0) return "not injected: a v4l2 fault on a GigE camera";
  if (e.kind == "host.network_delay")
    return "ms=" + e.text("ms", "50") + ", jitter_ms=" + e.text("jitter_ms", "0") +
           ", via=camera mock (GVSP datagrams held, order kept; frames' tx = the leader's real send)";
  return {};
}

}  // namespace

void set_gige_fake_chaos(GigeFakeChaos* chaos) { g_chaos.store(chaos, std::memory_order_release); }

GigeFakeChaos::GigeFakeChaos(const Options& o)
    : schedule_(o.args.plan, o.args.device), lost_ratio_(o.lost_per_thousand / 1000.0), link_mbps_(o.link_mbps) {
  if (!o.args.truth.empty())
    truth_ = std::make_unique<CameraTruth>(o.args.truth, o.args.device, "camera", "rig-fake-gige-camera (Aravis ArvGvFakeCamera)", kClock);
  if (!o.args.plan.empty()) {
    const faults::Plan plan = faults::read_plan(o.args.plan);
    hold_ = faults::NetworkHold(faults::NetworkHold::windows_of(plan, o.args.device));
    for (const auto& e : plan.for_device(o.args.device))
      if (e.kind == "host.network_delay" && e.device != "lo") delays_.push_back(e);
  }
  if (!hold_.empty()) sender_ = std::thread([this] { send_held(); });
}

GigeFakeChaos::~GigeFakeChaos() {
  {
    std::lock_guard lock(held_mutex_);
    held_stop_ = true;
  }
  held_cv_.notify_all();
  if (sender_.joinable()) sender_.join();
}

void GigeFakeChaos::release(Held& h, SendFn real) {
  if (h.record) {
    // A held datagram the socket refused (the camera rebooted meanwhile: the old stream's socket is
    // closed) never arrived: the frame is not whole.
    const bool failed = held_send_failed_ && h.fate == truth::Fate::kSent;
    if (truth_ != nullptr) {
      truth_->frame(h.unit, h.acq, h.dev, h.leader_held && last_leader_tx_ != 0 ? last_leader_tx_ : h.tx,
                    failed ? truth::Fate::kDropped : h.fate, h.fault, h.exposure);
      truth_->flush();  // as after_send's: a killed tool takes no frame the rig has with it
    }
    held_send_failed_ = false;
  } else {
    if (h.leader) {
      last_leader_tx_ = vehicle_now_ns();
      held_send_failed_ = false;
    }
    if (real != nullptr &&
        real(h.socket, h.address, reinterpret_cast<const gchar*>(h.bytes.data()), h.bytes.size(), nullptr, nullptr) < 0)
      held_send_failed_ = true;
  }
  if (h.socket != nullptr) g_object_unref(h.socket);
  if (h.address != nullptr) g_object_unref(h.address);
  h.socket = nullptr;
  h.address = nullptr;
}

void GigeFakeChaos::send_held() {
  std::unique_lock lock(held_mutex_);
  while (true) {
    if (held_.empty()) {
      if (held_stop_) return;
      held_cv_.wait(lock);
      continue;
    }
    const Nanos due = held_.front().due_mono;
    // Stopping: what the network still holds leaves now (the process ends; nothing is lost by the hold).
    if (!held_stop_ && monotonic_now_ns() < due) {
      held_cv_.wait_for(lock, std::chrono::nanoseconds(due - monotonic_now_ns()));
      continue;
    }
    release(held_.front(), held_real_);
    held_.pop_front();
  }
}

gssize GigeFakeChaos::transmit(SendFn real, GSocket* socket, GSocketAddress* address, const void* data, std::size_t size,
                               GCancellable* cancellable, GError** error) {
  if (hold_.empty() || !is_stream(socket)) return real(socket, address, static_cast<const gchar*>(data), size, cancellable, error);
  std::uint8_t type = 0;
  if (size >= gvsp::kHeader) std::memcpy(&type, static_cast<const std::uint8_t*>(data) + gvsp::kContentTypeOffset, 1);
  const bool leader = (type & 0x7f) == kLeader;
  const Nanos now = monotonic_now_ns();
  const auto due = hold_.due(now);
  std::unique_lock lock(held_mutex_);
  if (held_.empty() && due.at_mono <= now) return real(socket, address, static_cast<const gchar*>(data), size, cancellable, error);
  // Held, or behind a held one: in order, at its time.
  Held h;
  h.due_mono = due.at_mono;
  h.bytes.assign(static_cast<const std::uint8_t*>(data), static_cast<const std::uint8_t*>(data) + size);
  h.socket = G_SOCKET(g_object_ref(socket));
  h.address = address != nullptr ? G_SOCKET_ADDRESS(g_object_ref(address)) : nullptr;
  h.leader = leader;
  held_real_ = real;
  held_.push_back(std::move(h));
  if (leader) frame_leader_held_ = true;
  if (due.fault != 0) frame_held_by_ = due.fault;
  lock.unlock();
  held_cv_.notify_all();
  return static_cast<gssize>(size);
}

void GigeFakeChaos::after_send(GSocket* socket) {
  if (!is_stream(socket) || !frame_truth_due_) return;
  frame_truth_due_ = false;
  const auto fate = frame_.sent == 0 && frame_.silenced > 0    ? truth::Fate::kNotSent
                    : frame_.lost + frame_.silenced > 0 ? truth::Fate::kDropped
                                                        : truth::Fate::kSent;
  // The fault that decided its fate; a frame delivered whole but late: the delay that held it.
  const std::uint64_t fault = fate == truth::Fate::kSent ? frame_held_by_ : frame_.fault;
  {
    std::unique_lock lock(held_mutex_);
    if (!held_.empty()) {
      Held h;
      h.due_mono = held_.back().due_mono;
      h.record = true;
      h.unit = frame_.unit;
      h.acq = frame_.acq;
      h.dev = frame_.dev;
      h.tx = frame_.tx;
      h.exposure = frame_.exposure_ns;
      h.fate = fate;
      h.fault = fault;
      h.leader_held = frame_leader_held_;
      held_.push_back(std::move(h));
      lock.unlock();
      held_cv_.notify_all();
      return;
    }
  }
  truth_->frame(frame_.unit, frame_.acq, frame_.dev, frame_.tx, fate, fault, frame_.exposure_ns);
  // On disk with the frame's last datagram, as every mock's (the in-process fakes', the LIDARs' per
  // batch): a tool killed (SIGKILL, or after its 1 s of grace at the rig's stop) took the frames of
  // the writer's buffer with it, frames the rig had published (4 KiB: ~20; 64 KiB: ~300).
  truth_->flush();
}

void GigeFakeChaos::booted(ArvFakeCamera* cam) {
  gvsp_ = nullptr;
  // A camera.dies that ended is over once the camera (re)started (tick()); one still due holds.
  if (schedule_.active("camera.dies", schedule_.now_s()) == nullptr) dies_.store(0, std::memory_order_release);
  if (answered_.exchange(0) > 0 || frame_.unit >= 0) units_.reboot();  // frame ids start again at 1
  frame_ = {};
  if (cam == nullptr) return;
  update_ptp(cam, schedule_.now_s());
  // What its PayloadSize counts (fake_cameras.hpp chaos_chunk_genicam_xml): the widest padding and
  // the chunks its plan will have it send, as a camera configured so would say from the start.
  std::uint32_t widest = 0;
  for (const auto& e : schedule_.events())
    if (e.kind == "camera.padded_rows") widest = std::max(widest, static_cast<std::uint32_t>(std::max(0.0, e.number("bytes", 64))));
  arv_fake_camera_write_register(cam, kChaosRowPaddingRegister, widest);
  arv_fake_camera_write_register(cam, kChaosChunkPlanRegister, schedule_.has("camera.chunk_data") ? 1 : 0);
}

GvspFrameShape GigeFakeChaos::shape_of(ArvFakeCamera* cam, double t, std::uint64_t dev_ns, std::uint32_t exposure_us) const {
  GvspFrameShape shape;
  if (const auto* pad = schedule_.active("camera.padded_rows", t))
    shape.pad_bytes = static_cast<std::uint32_t>(std::max(0.0, pad->number("bytes", 64)));
  guint32 chunk_mode = 0;
  arv_fake_camera_read_register(cam, kChaosChunkModeRegister, &chunk_mode);
  const auto* chunk = schedule_.active("camera.chunk_data", t);
  shape.chunks = (chunk_mode & 1) != 0 || chunk != nullptr;
  if (chunk != nullptr && chunk->text("payload") == "chunk") shape.payload_type = 0x0004;
  shape.multipart = chunk != nullptr && chunk->text("payload") == "multipart";
  shape.chunk_timestamp = dev_ns;
  shape.chunk_exposure_us = exposure_us;
  return shape;
}

bool GigeFakeChaos::is_stream(GSocket* socket) {
  if (gvsp_ == nullptr && socket != nullptr) {
    // The stream socket is the one not on the GVCP port (control and discovery acks are).
    if (GSocketAddress* local = g_socket_get_local_address(socket, nullptr)) {
      if (g_inet_socket_address_get_port(G_INET_SOCKET_ADDRESS(local)) != kGvcpPort) gvsp_ = socket;
      g_object_unref(local);
    }
  }
  return socket != nullptr && socket == gvsp_;
}

bool GigeFakeChaos::reshape(GSocket* socket, const void* data, std::size_t size, const GvspReshaper::Emit& emit) {
  if (!is_stream(socket)) return false;
  return reshaper_.feed(static_cast<const std::uint8_t*>(data), size, shape_, emit);
}

std::uint64_t GigeFakeChaos::silenced_by(double t) const {
  if (const auto* e = schedule_.active("camera.never_answers", t)) return e->id;
  if (const auto d = dies_.load(std::memory_order_acquire)) return d;
  if (const auto s = slow_.load(std::memory_order_acquire)) {
    const Nanos first = slow_first_rx_.load(std::memory_order_acquire);
    if (first == 0 || monotonic_now_ns() < first + static_cast<Nanos>(slow_after_s_.load() * 1e9)) return s;
  }
  return 0;
}

bool GigeFakeChaos::tick() {
  const double t = schedule_.now_s();
  bool reboot = false;
  for (const auto& e : schedule_.events()) {
    if (e.at_s > t) continue;
    if (truth_ != nullptr)  // once per event (the writer keeps the ids)
      truth_->fault(e, schedule_.vehicle_ns(e.at_s), schedule_.vehicle_ns(e.at_s + e.duration_s), -1, detail_of(e));
    // A slow open begins once, when its time comes (a fake restarted long after it does not redo it).
    if (e.kind == "camera.slow_open" && t - e.at_s < kSlowOpenLateS && slow_started_.insert(e.id).second) {
      // The camera (re)starts slowly: a running one reboots first, and answers s after the first request.
      slow_first_rx_.store(0);
      slow_after_s_.store(e.number("s", 3));
      slow_.store(e.id, std::memory_order_release);
      reboot = reboot || answered_.load() > 0;
    }
  }
  if (truth_ != nullptr)  // host.network_delay: the frames it holds name it
    for (const auto& e : delays_)
      if (e.at_s <= t) truth_->fault(e, schedule_.vehicle_ns(e.at_s), schedule_.vehicle_ns(e.at_s + e.duration_s), -1, detail_of(e));
  const auto* dead = schedule_.active("camera.dies", t);
  if (dead != nullptr) {
    dies_.store(dead->id, std::memory_order_release);
  } else if (dies_.load(std::memory_order_acquire) != 0) {
    // It returns as from a power cycle: fresh registers, no controller, ids from 1. Silent until
    // the restart is done (booted() ends the silence): the stream thread of the acquisition it
    // died in runs until the restart joins it, and sent one more frame to the old stream, recorded
    // "sent" (rig chaos: "neither published nor counted lost", 12-90 ms after each fault's end).
    reboot = true;
  }
  return reboot;
}

std::uint32_t GigeFakeChaos::on_fill(ArvFakeCamera* cam, ArvBuffer* buffer, std::uint32_t exposure_us) {
  const double t = schedule_.now_s();
  const auto id = arv_buffer_get_frame_id(buffer);
  const auto step = exposure_.step(schedule_, t, id, exposure_us);
  if (step.write) arv_fake_camera_write_register(cam, ARV_FAKE_CAMERA_REGISTER_EXPOSURE_TIME_US, step.us);
  const Nanos stamp = static_cast<Nanos>(arv_buffer_get_timestamp(buffer));
  Nanos dev = stamp;
  if (needs_ptp_features()) {
    guint32 enable = 0;
    arv_fake_camera_read_register(cam, kChaosPtpEnableRegister, &enable);
    dev = std::max<Nanos>(0, stamp + ptp_at(schedule_, t, (enable & 1) != 0).offset_ns);
    if (dev != stamp) arv_buffer_set_timestamp(buffer, static_cast<guint64>(dev));
  }
  frame_ = Frame{units_.unit(id), stamp, dev, 0, 0, 0, 0, 0};
  shape_ = shape_of(cam, t, static_cast<std::uint64_t>(dev), step.us);
  if (truth_ != nullptr && shape_.chunks) frame_.exposure_ns = Nanos{step.us} * 1000;  // what its chunk says
  return step.us;
}

void GigeFakeChaos::restamp(ArvBuffer* buffer, Nanos late_ns) {
  if (late_ns <= 0) return;
  frame_.acq += late_ns;
  frame_.dev += late_ns;
  shape_.chunk_timestamp = static_cast<std::uint64_t>(frame_.dev);
  arv_buffer_set_timestamp(buffer, static_cast<guint64>(frame_.dev));
}

void GigeFakeChaos::pace(GSocket* socket, const void* data, std::size_t bytes) {
  if (!is_stream(socket)) return;
  std::uint8_t type = 0;
  if (bytes >= gvsp::kHeader) std::memcpy(&type, static_cast<const std::uint8_t*>(data) + gvsp::kContentTypeOffset, 1);
  const Nanos now = monotonic_now_ns();
  Nanos until_ns = now;
  if ((type & 0x7f) == kLeader) until_ns = now + kLeaderGapNs;
  if (link_mbps_ > 0) {
    // On the wire a datagram also carries its IP/UDP headers (28) and Ethernet's header, FCS,
    // preamble and gap (38).
    constexpr std::size_t kFraming = 28 + 38;
    constexpr Nanos kPaceStepNs = 50'000;
    link_free_mono_ = std::max(link_free_mono_, now) + static_cast<Nanos>(static_cast<double>(bytes + kFraming) * 8e3 / link_mbps_);
    if (link_free_mono_ - now >= kPaceStepNs) until_ns = std::max(until_ns, link_free_mono_);
  }
  if (until_ns <= now) return;
  const timespec until{static_cast<time_t>(until_ns / 1'000'000'000), static_cast<long>(until_ns % 1'000'000'000)};
  while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, nullptr) == EINTR) {
  }
}

bool GigeFakeChaos::on_send(GSocket* socket, const void* data, std::size_t size) {
  const double t = schedule_.now_s();
  const std::uint64_t silent = silenced_by(t);
  if (!is_stream(socket)) return silent == 0;
  std::uint8_t type = 0;
  if (size >= gvsp::kHeader) std::memcpy(&type, static_cast<const std::uint8_t*>(data) + gvsp::kContentTypeOffset, 1);
  type &= 0x7f;
  if (type == kLeader) {
    frame_.tx = vehicle_now_ns();
    frame_.sent = frame_.lost = frame_.silenced = 0;
    frame_.fault = 0;
    frame_leader_held_ = false;
    frame_held_by_ = 0;
  }
  bool send = true;
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  if (silent != 0) {
    ++frame_.silenced;
    frame_.fault = silent;
    send = false;
  } else if (const auto* loss = schedule_.active("camera.packet_loss", t); loss != nullptr && uniform(rng_) < loss->number("p", 0.01)) {
    ++frame_.lost;
    frame_.fault = loss->id;
    send = false;
  } else if (lost_ratio_ > 0 && uniform(rng_) < lost_ratio_) {
    ++frame_.lost;
    send = false;
  }
  if (send) ++frame_.sent;
  // Its truth line once the trailer went or was lost (after_send: a held trailer leaves later).
  if (type == kTrailer && truth_ != nullptr && frame_.unit >= 0) frame_truth_due_ = true;
  return send;
}

bool GigeFakeChaos::on_receive(ArvFakeCamera* cam) {
  if (slow_.load(std::memory_order_acquire) != 0 && slow_first_rx_.load() == 0) slow_first_rx_.store(monotonic_now_ns());
  const double t = schedule_.now_s();
  if (silenced_by(t) != 0) return false;
  if (cam != nullptr) update_ptp(cam, t);  // a status read sees the state of this instant
  answered_.fetch_add(1, std::memory_order_relaxed);
  return true;
}

void GigeFakeChaos::update_ptp(ArvFakeCamera* cam, double t) {
  if (!needs_ptp_features()) return;
  guint32 enable = 0;
  arv_fake_camera_read_register(cam, kChaosPtpEnableRegister, &enable);
  arv_fake_camera_write_register(cam, kChaosPtpStatusRegister, static_cast<guint32>(ptp_at(schedule_, t, (enable & 1) != 0).state));
}

void GigeFakeChaos::finish() {
  if (sender_.joinable()) {  // what is still held leaves now, its truth lines with it
    {
      std::lock_guard lock(held_mutex_);
      held_stop_ = true;
    }
    held_cv_.notify_all();
    sender_.join();
  }
  if (truth_ != nullptr) truth_->flush();
}

}  // namespace sensor_rig::camera::mock

namespace {
template <typename F>
F real_function(const char* name) {
  void* p = ::dlsym(RTLD_NEXT, name);
  F f = nullptr;
  static_assert(sizeof f == sizeof p);
  std::memcpy(&f, &p, sizeof f);
  return f;
}
std::atomic<ArvFakeCamera*> g_receive_camera{nullptr};
}  // namespace

namespace sensor_rig::camera::mock {
void set_gige_fake_camera(ArvFakeCamera* cam) { g_receive_camera.store(cam, std::memory_order_release); }
}  // namespace sensor_rig::camera::mock

// libaravis's fake calls these through the PLT: these definitions are the ones it gets; each hands
// the datagram to the chaos instance and then, unless it says no, to GLib's own.
extern "C" gssize g_socket_send_to(GSocket* socket, GSocketAddress* address, const gchar* buffer, gsize size,
                                   GCancellable* cancellable, GError** error) {
  static const auto real = real_function<decltype(&g_socket_send_to)>("g_socket_send_to");
  auto* chaos = sensor_rig::camera::mock::g_chaos.load(std::memory_order_acquire);
  if (chaos == nullptr) return real(socket, address, buffer, size, cancellable, error);
  // A frame with padded rows or chunks goes out as the datagrams the reshaper makes, each through
  // the chaos (lost, silenced, recorded) as the fake's own would.
  // A send that fails is the fake's to ignore (it only logs them): no GError for the many datagrams.
  const bool reshaped = chaos->reshape(socket, buffer, size, [&](const std::uint8_t* d, std::size_t n) {
    if (chaos->on_send(socket, d, n)) chaos->transmit(real, socket, address, d, n, cancellable, nullptr);
    chaos->after_send(socket);
    chaos->pace(socket, d, n);
  });
  if (reshaped) return static_cast<gssize>(size);
  if (!chaos->on_send(socket, buffer, size)) {  // lost on the way (after it took its time on the link)
    chaos->after_send(socket);
    chaos->pace(socket, buffer, size);
    return static_cast<gssize>(size);
  }
  const gssize sent = chaos->transmit(real, socket, address, buffer, size, cancellable, error);
  chaos->after_send(socket);
  chaos->pace(socket, buffer, size);
  return sent;
}

extern "C" gssize g_socket_receive_message(GSocket* socket, GSocketAddress** address, GInputVector* vectors, gint num_vectors,
                                           GSocketControlMessage*** messages, gint* num_messages, gint* flags,
                                           GCancellable* cancellable, GError** error) {
  static const auto real = real_function<decltype(&g_socket_receive_message)>("g_socket_receive_message");
  const gssize n = real(socket, address, vectors, num_vectors, messages, num_messages, flags, cancellable, error);
  auto* chaos = sensor_rig::camera::mock::g_chaos.load(std::memory_order_acquire);
  if (n > 0 && chaos != nullptr && !chaos->on_receive(g_receive_camera.load(std::memory_order_acquire))) return 0;  // unanswered
  return n;
}
