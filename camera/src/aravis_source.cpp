#include "sensor_rig/camera/aravis_source.hpp"

#include <arpa/inet.h>
#include <arv.h>

#include <mutex>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <thread>
#include <vector>

#include "exposure_watcher.hpp"
#include "gvsp_payload.hpp"
#include "sensor_rig/common/log.hpp"
#include "socket_buffer.hpp"

namespace sensor_rig::camera {
namespace {

// How long trigger() waits for the camera's locks (see trigger()).
constexpr int kTriggerLockWaitMs = 5;

// GError -> CameraError text; frees the error.
std::string take_error(GError*& e) {
  std::string s = e != nullptr && e->message != nullptr ? e->message : "unknown error";
  if (e != nullptr) g_error_free(e);
  e = nullptr;
  return s;
}

template <class T>
void unref(T*& p) noexcept {
  if (p != nullptr) g_object_unref(p);
  p = nullptr;
}

// A GenICam feature's value as text; "" and `error` set when absent or unreadable.
std::string feature_text(ArvDevice* dev, const char* name, std::string& error) {
  ArvGcNode* node = arv_device_get_feature(dev, name);
  if (node == nullptr || !ARV_IS_GC_FEATURE_NODE(node)) {
    error = std::string("no feature ") + name;
    return {};
  }
  GError* err = nullptr;
  const char* v = arv_gc_feature_node_get_value_as_string(reinterpret_cast<ArvGcFeatureNode*>(node), &err);
  if (err != nullptr) {
    error = std::string(name) + ": " + take_error(err);
    return {};
  }
  return v != nullptr ? v : "";
}


void on_control_lost(ArvDevice* /*device*/, gpointer user) {
  static_cast<std::atomic<bool>*>(user)->store(true);
}

}  // namespace

struct AravisSource::State {
  ArvCamera* camera = nullptr;
  ArvDevice* device = nullptr;  // borrowed from camera
  ArvStream* stream = nullptr;
  bool gv = false;
  std::unique_ptr<BufferPool> pool;
  std::vector<ArvBuffer*> buffers;  // owned by the stream once pushed
  std::size_t payload = 0;
  std::uint64_t seq = 0;
  detail::ChunkReader chunks;  // the capture thread's
};

// Aravis 0.8 parses each device's GenICam XML while opening it, and opening from several threads at
// once corrupts its DOM (GLib criticals, and a SIGFPE seen in `rig demo` with seven cameras opening
// together): one open at a time in the process. A dead camera's open (GVCP timeouts) delays the others'.
namespace {
std::mutex& aravis_open_mutex() {
  static std::mutex m;
  return m;
}
}  // namespace

void* open_aravis_network_device(const std::string& device) {
  GError* err = nullptr;
  ArvDevice* d = arv_open_device(device.c_str(), &err);
  if (d != nullptr) return d;
  const std::string first = take_error(err);
  // An address needs no discovery: Aravis already tried it (a dead camera's attempt then costs its
  // GVCP timeouts, ~0.1 s, instead of a second of broadcast discovery on every retry).
  in_addr ip{};
  if (::inet_pton(AF_INET, device.c_str(), &ip) == 1) throw CameraError("aravis " + device + ": " + first);
  // A bare serial number is not one of Aravis' keys: find it in the device list.
  arv_update_device_list();
  for (unsigned i = 0; i < arv_get_n_devices(); ++i) {
    const char* serial = arv_get_device_serial_nbr(i);
    if (serial == nullptr || device != serial) continue;
    d = arv_open_device(arv_get_device_id(i), &err);
    if (d != nullptr) return d;
    throw CameraError("aravis " + device + ": " + take_error(err));
  }
  throw CameraError("aravis " + device + ": " + first);
}

AravisSource::AravisSource(SourceConfig cfg, AravisDeviceOpener opener)
    : cfg_(std::move(cfg)), opener_(std::move(opener)), st_(std::make_unique<State>()) {
  if (!opener_) opener_ = open_aravis_network_device;
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

// Everything that talks to the device runs on a State of its own, with none of the locks trigger()
// takes: a camera that does not answer costs its own opener time, never its trigger group's
// (issue 27 item 1). The new state is installed under the locks at the end, then triggers pass.
void AravisSource::open() {
  close();
  auto fresh = std::make_unique<State>();
  {
    std::lock_guard lock(mutex_);
    fresh->pool = std::move(st_->pool);  // reused when the size matches (start_stream)
  }
  control_lost_.store(false);
  last_frame_id_ = 0;  // a reopened camera may have restarted its ids
  last_exposure_ns_.store(0);
  AravisDetails details;
  try {
    {
      std::lock_guard one_open_at_a_time(aravis_open_mutex());  // GenICam XML parsing only
      auto* device = static_cast<ArvDevice*>(opener_(cfg_.device));  // throws CameraError
      GError* err = nullptr;
      fresh->camera = arv_camera_new_with_device(device, &err);
      g_object_unref(device);  // the camera holds its own reference
      if (fresh->camera == nullptr) throw CameraError("aravis " + cfg_.device + ": " + take_error(err));
    }
    fresh->device = arv_camera_get_device(fresh->camera);
    fresh->gv = arv_camera_is_gv_device(fresh->camera) != FALSE;
    g_signal_connect_data(fresh->device, "control-lost", reinterpret_cast<GCallback>(&on_control_lost), &control_lost_,
                          nullptr, GConnectFlags{});
    configure(*fresh, details);
    start_stream(*fresh);
    if (fresh->gv) {  // the kernel caps Aravis' SO_RCVBUF silently: say what was granted, once
      const auto sb = detail::check_socket_buffer(cfg_.socket_buffer_bytes, fresh->payload);
      socket_granted_.store(sb.granted);
      socket_needed_.store(sb.needed);
      if (sb.short_of_frame() && !socket_warned_.exchange(true)) log::warn("camera", detail::socket_buffer_advice(cfg_.device, sb));
    }
  } catch (...) {
    if (fresh->stream != nullptr) arv_stream_set_emit_signals(fresh->stream, FALSE);
    if (fresh->device != nullptr)
      g_signal_handlers_disconnect_matched(fresh->device, G_SIGNAL_MATCH_DATA, 0, 0, nullptr, nullptr, &control_lost_);
    unref(fresh->stream);
    unref(fresh->camera);
    throw;
  }
  {
    std::lock_guard lock(mutex_);
    std::lock_guard gl(*gc_mutex_);
    st_ = std::move(fresh);
    details_ = details;
  }
  open_.store(true);
  streaming_.store(true);
  {
    std::lock_guard pl(ptp_mutex_);
    ptp_stop_ = false;
  }
  if (!exposure_read_feature_.empty())
    exposure_ = std::make_unique<detail::ExposureWatcher>(st_->device, exposure_read_feature_, gc_mutex_);
  if (cfg_.ptp.enable) ptp_thread_ = std::thread([this] { status_loop(); });
}

// The PTP status thread: a GVCP round trip every status_poll_ms, never on the capture thread.
void AravisSource::status_loop() {
  const auto period = std::chrono::milliseconds(std::max(cfg_.ptp.status_poll_ms, 10));
  std::unique_lock pl(ptp_mutex_);
  while (!ptp_cv_.wait_for(pl, period, [this] { return ptp_stop_; })) {
    pl.unlock();
    {
      std::lock_guard gl(*gc_mutex_);
      if (!control_lost_.load()) poll_ptp();
    }
    pl.lock();
  }
}

void AravisSource::configure(State& st, AravisDetails& details) {
  ArvCamera* cam = st.camera;
  ArvDevice* dev = st.device;
  GError* err = nullptr;
  const auto check = [&](const std::string& what) {
    if (err != nullptr) throw CameraError("aravis " + cfg_.device + ": " + what + ": " + take_error(err));
  };
  details = {};
  if (const char* v = arv_camera_get_vendor_name(cam, nullptr)) details.vendor = v;
  if (const char* v = arv_camera_get_model_name(cam, nullptr)) details.model = v;
  if (const char* v = arv_camera_get_device_serial_number(cam, nullptr)) details.serial = v;
  // 0. stopped: a device its last controller left acquiring (our own handle released after
  // mark_lost(), a crashed process) keeps its stream going to that controller's old port, and
  // many cameras lock format and ROI while acquiring (camera/README.md "Reopening a live camera").
  // Refused (a device that is not acquiring, no AcquisitionStop): the steps below say what fails.
  arv_camera_stop_acquisition(cam, &err);
  if (err != nullptr) take_error(err);
  // 1. pixel format (the device must offer it), 2. ROI.
  arv_camera_set_pixel_format_from_string(cam, info(cfg_.format).genicam, &err);
  check(std::string("PixelFormat ") + info(cfg_.format).genicam);
  arv_camera_set_region(cam, 0, 0, static_cast<gint>(cfg_.width), static_cast<gint>(cfg_.height), &err);
  check("region " + std::to_string(cfg_.width) + "x" + std::to_string(cfg_.height));
  gint x = 0, y = 0, w = 0, h = 0;
  arv_camera_get_region(cam, &x, &y, &w, &h, &err);
  check("region");
  if (static_cast<std::uint32_t>(w) != cfg_.width || static_cast<std::uint32_t>(h) != cfg_.height)
    throw CameraError("aravis " + cfg_.device + ": device gives " + std::to_string(w) + "x" + std::to_string(h) +
                      " instead of " + std::to_string(cfg_.width) + "x" + std::to_string(cfg_.height));
  // 3. frame rate (free run and line trigger: the device's; software trigger: our ticker's).
  if (arv_camera_is_frame_rate_available(cam, nullptr) != FALSE) {
    arv_camera_set_frame_rate(cam, cfg_.frame_rate, &err);
    check("frame rate " + std::to_string(cfg_.frame_rate));
    details.frame_rate = arv_camera_get_frame_rate(cam, nullptr);
  }
  // 4. exposure: SFNC ExposureTime, older cameras ExposureTimeAbs.
  if (cfg_.exposure_us > 0) {
    std::string tried;
    for (const char* name : {"ExposureTime", "ExposureTimeAbs"}) {
      if (arv_device_is_feature_available(dev, name, nullptr) == FALSE) continue;
      arv_device_set_float_feature_value(dev, name, cfg_.exposure_us, &err);
      if (err == nullptr) {
        details.exposure_feature = name;
        break;
      }
      tried += std::string(name) + ": " + take_error(err) + "; ";
    }
    if (details.exposure_feature.empty())
      throw CameraError("aravis " + cfg_.device + ": exposure " + std::to_string(cfg_.exposure_us) + " us: " +
                        (tried.empty() ? "no ExposureTime/ExposureTimeAbs feature" : tried));
  }
  // 5. gain.
  if (cfg_.gain_db >= 0) {
    arv_camera_set_gain(cam, cfg_.gain_db, &err);
    check("gain " + std::to_string(cfg_.gain_db));
  }
  // 6. any feature by name, in config order.
  for (const auto& [name, value] : cfg_.features) {
    std::string assignment = name;
    assignment.append("=").append(value);
    arv_device_set_features_from_string(dev, assignment.c_str(), &err);
    check("feature " + assignment);
  }
  st.chunks.set_tick_hz(detail::timestamp_tick_hz(dev));  // ChunkTimestamp ticks -> ns
  exposure_read_feature_.clear();
  // What the device has after the features (one may set ExposureTime, issue 27 item 9): the frame clock's exposure -> leader delay.
  for (const char* name : {"ExposureTime", "ExposureTimeAbs"}) {
    if (arv_device_is_feature_available(dev, name, nullptr) == FALSE) continue;
    const double us = arv_device_get_float_feature_value(dev, name, &err);
    if (err != nullptr) {
      take_error(err);
      continue;
    }
    details.exposure_us = us;
    exposure_read_feature_ = name;
    break;
  }
  // 6b. PTP, after the features (a feature may select the PTP profile or clock).
  ptp_locked_.store(false);
  {
    std::lock_guard pl(ptp_mutex_);
    const auto resets = ptp_.resets;
    ptp_ = {};
    ptp_.resets = resets;  // across reopens
  }
  if (cfg_.ptp.enable) setup_ptp(dev);  // the status thread starts after open
  // 7. trigger.
  switch (cfg_.trigger) {
    case TriggerMode::kFreeRun:
      arv_camera_clear_triggers(cam, &err);
      check("clear triggers");
      break;
    case TriggerMode::kSoftware:
      arv_camera_set_trigger(cam, "Software", &err);
      check("software trigger");
      break;
    case TriggerMode::kLine:
      set_line_trigger(cam);
      break;
  }
  // GigE transport: packet size (or negotiated), inter-packet delay, no packet socket.
  if (st.gv) {
    if (cfg_.packet_size > 0) {
      arv_camera_gv_set_packet_size(cam, cfg_.packet_size, &err);
      check("packet size");
    } else {
      (void)arv_camera_gv_auto_packet_size(cam, &err);
      if (err != nullptr) take_error(err);  // keep the device's packet size
    }
    if (cfg_.packet_delay_ns > 0) {
      arv_camera_gv_set_packet_delay(cam, cfg_.packet_delay_ns, &err);
      check("packet delay");
    }
    details.packet_size = static_cast<int>(arv_camera_gv_get_packet_size(cam, nullptr));
    arv_camera_gv_set_stream_options(
        cam, cfg_.packet_socket ? ARV_GV_STREAM_OPTION_NONE : ARV_GV_STREAM_OPTION_PACKET_SOCKET_DISABLED);
  }
}

// FrameStart on the configured line and edge (arv_camera_set_trigger: every other trigger off,
// AcquisitionFrameRateEnable off, RisingEdge where offered). The line must be one the device lists.
void AravisSource::set_line_trigger(ArvCamera* cam) {
  const std::string& line = cfg_.trigger_line;
  const std::string& edge = cfg_.trigger_activation;
  const std::string what = "aravis " + cfg_.device + ": line trigger ";
  if (arv_camera_is_enumeration_entry_available(cam, "TriggerSource", line.c_str(), nullptr) == FALSE) {
    guint n = 0;
    const char** offered = arv_camera_dup_available_enumerations_as_strings(cam, "TriggerSource", &n, nullptr);
    std::string names;
    for (guint i = 0; i < n; ++i) names += (i > 0 ? ", " : "") + std::string(offered[i]);
    g_free(static_cast<gpointer>(offered));
    if (names.empty()) names = "no TriggerSource";
    throw CameraError(what + "TriggerSource " + line + ": not offered (" + names + ")");
  }
  GError* err = nullptr;
  arv_camera_set_trigger(cam, line.c_str(), &err);
  if (err != nullptr) throw CameraError(what + line + ": " + take_error(err));
  // A device without TriggerActivation fires on its one edge: only another edge is an error.
  if (edge == "RisingEdge" && arv_camera_is_feature_available(cam, "TriggerActivation", nullptr) == FALSE) return;
  arv_camera_set_string(cam, "TriggerActivation", edge.c_str(), &err);
  if (err != nullptr) throw CameraError(what + "TriggerActivation " + edge + ": " + take_error(err));
}

std::string AravisSource::read_ptp_status(ArvDevice* dev, std::string& error) {
  const Nanos t0 = monotonic_now_ns();
  if (!ptp_latch_feature_.empty()) {  // SFNC: the status is the latched data set's
    GError* err = nullptr;
    arv_device_execute_command(dev, ptp_latch_feature_.c_str(), &err);
    if (err != nullptr) error = ptp_latch_feature_ + ": " + take_error(err);
  }
  std::string status = error.empty() ? feature_text(dev, ptp_status_feature_.c_str(), error) : std::string();
  const auto us = static_cast<std::int64_t>((monotonic_now_ns() - t0) / 1000);
  std::lock_guard pl(ptp_mutex_);
  ++ptp_.polls;
  ptp_.poll_max_us = std::max(ptp_.poll_max_us, us);
  return status;
}

// Disable and enable; "" or what failed. The caller counts it with the status read after it.
std::string AravisSource::ptp_reset(ArvDevice* dev, const std::string& status) {
  std::string name;
  {
    std::lock_guard pl(ptp_mutex_);
    name = ptp_.enable_feature;
  }
  GError* err = nullptr;
  arv_device_set_boolean_feature_value(dev, name.c_str(), FALSE, &err);
  if (err == nullptr) arv_device_set_boolean_feature_value(dev, name.c_str(), TRUE, &err);
  return err == nullptr ? std::string() : "reset of " + name + " (status " + status + "): " + take_error(err);
}

// One update of what ptp() reports: a reset is counted with the status read after it.
void AravisSource::publish_ptp(const std::string& status, bool reset, const std::string& error) {
  std::lock_guard pl(ptp_mutex_);
  if (reset) ++ptp_.resets;
  if (!error.empty()) ptp_.error = error;
  ptp_.status = status;
  // Only Slave follows the PU's grandmaster; Master is the camera's own clock unless it is meant to be.
  ptp_.locked = status == "Slave" || (status == "Master" && cfg_.ptp.grandmaster);
  ptp_locked_.store(ptp_.locked);
}

void AravisSource::setup_ptp(ArvDevice* dev) {
  std::string name;
  for (const char* f : {"PtpEnable", "GevIEEE1588"})
    if (arv_device_is_feature_available(dev, f, nullptr) != FALSE) {
      name = f;
      break;
    }
  if (name.empty())
    throw CameraError("aravis " + cfg_.device + ": ptp enabled but the device has no PtpEnable or GevIEEE1588 feature");
  ptp_status_feature_ = name == "PtpEnable" ? "PtpStatus" : "GevIEEE1588Status";
  if (arv_device_is_feature_available(dev, ptp_status_feature_.c_str(), nullptr) == FALSE)
    throw CameraError("aravis " + cfg_.device + ": ptp enabled but the device has " + name + " and no " + ptp_status_feature_);
  ptp_latch_feature_ = name == "PtpEnable" ? "PtpDataSetLatch" : "GevIEEE1588DataSetLatch";
  if (arv_device_is_feature_available(dev, ptp_latch_feature_.c_str(), nullptr) == FALSE) ptp_latch_feature_.clear();
  GError* err = nullptr;
  arv_device_set_boolean_feature_value(dev, name.c_str(), TRUE, &err);
  if (err != nullptr) throw CameraError("aravis " + cfg_.device + ": " + name + "=true: " + take_error(err));
  {
    std::lock_guard pl(ptp_mutex_);
    ptp_.enabled = true;
    ptp_.enable_feature = name;
  }
  std::string error;
  std::string status = read_ptp_status(dev, error);
  if (!error.empty()) throw CameraError("aravis " + cfg_.device + ": " + error);
  // Not running (yet): disable and enable once, as a faulty clock servo needs.
  const bool reset = status == "Faulty" || status == "Disabled" || status == "Initializing";
  std::string reset_error;
  if (reset) {
    reset_error = ptp_reset(dev, status);
    status = read_ptp_status(dev, error);
    if (!error.empty()) throw CameraError("aravis " + cfg_.device + ": " + error);
  }
  publish_ptp(status, reset, reset_error);
}

void AravisSource::poll_ptp() {
  ArvDevice* dev = st_->device;
  if (dev == nullptr) return;
  std::string error;
  std::string status = read_ptp_status(dev, error);
  // Faulty/Disabled: reset. Initializing is what a reset leads to: wait for it.
  const bool reset = error.empty() && (status == "Faulty" || status == "Disabled");
  if (reset) {
    const std::string reset_error = ptp_reset(dev, status);
    status = read_ptp_status(dev, error);
    if (error.empty()) error = reset_error;
  }
  if (!error.empty() && status.empty()) status = "unknown";  // the read failed
  publish_ptp(status, reset, error);
}

void AravisSource::stop_ptp_thread() noexcept {
  if (!ptp_thread_.joinable()) return;
  {
    std::lock_guard pl(ptp_mutex_);
    ptp_stop_ = true;
  }
  ptp_cv_.notify_all();
  ptp_thread_.join();
}

PtpState AravisSource::ptp() const {
  std::lock_guard pl(ptp_mutex_);
  return ptp_;
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

void AravisSource::start_stream(State& st) {
  GError* err = nullptr;
  st.payload = arv_camera_get_payload(st.camera, &err);
  if (err != nullptr) throw CameraError("aravis " + cfg_.device + ": payload: " + take_error(err));
  const std::size_t image = frame_bytes(cfg_.format, cfg_.width, cfg_.height);
  if (st.payload < image) st.payload = image;
  if (!st.pool || st.pool->bytes() != st.payload || st.pool->count() != static_cast<std::size_t>(cfg_.buffers))
    st.pool = std::make_unique<BufferPool>(static_cast<std::size_t>(cfg_.buffers), st.payload);
  st.stream = arv_camera_create_stream(st.camera, nullptr, nullptr, &err);
  if (st.stream == nullptr) throw CameraError("aravis " + cfg_.device + ": stream: " + take_error(err));
  if (st.gv) {
    g_object_set(st.stream, "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_FIXED, "socket-buffer-size",
                 static_cast<gint>(cfg_.socket_buffer_bytes), "packet-timeout", 20'000u, "frame-retention",
                 static_cast<guint>(std::max(100'000.0, 2e6 / std::max(cfg_.frame_rate, 1.0))), nullptr);
  }
  // Every pool buffer becomes one stream buffer, once: Aravis writes the image into pool memory.
  st.buffers.clear();
  for (std::size_t i = 0; i < st.pool->count(); ++i) {
    auto buf = st.pool->buffer(i);
    // The pool index rides in the buffer's user data (GLib's GUINT_TO_POINTER idiom).
    ArvBuffer* b = arv_buffer_new_full(st.payload, buf.data(), reinterpret_cast<gpointer>(static_cast<std::uintptr_t>(i)), nullptr);  // NOLINT(performance-no-int-to-ptr)
    st.buffers.push_back(b);
    arv_stream_push_buffer(st.stream, b);
  }
  arv_camera_start_acquisition(st.camera, &err);
  if (err != nullptr) throw CameraError("aravis " + cfg_.device + ": start acquisition: " + take_error(err));
}

void AravisSource::fold_stats() noexcept {
  if (st_->stream == nullptr) return;
  guint64 completed = 0, failures = 0, underruns = 0;
  arv_stream_get_statistics(st_->stream, &completed, &failures, &underruns);
  base_.underruns += underruns;
  if (st_->gv) {
    guint64 resent = 0, missing = 0;
    arv_gv_stream_get_statistics(reinterpret_cast<ArvGvStream*>(st_->stream), &resent, &missing);
    base_.resent_packets += resent;
    base_.missing_packets += missing;
  }
}

void AravisSource::close() noexcept {
  streaming_.store(false);  // triggers refuse from here on, without waiting for this close
  if (exposure_) {  // a read on a dead camera takes seconds: not waited for
    if (control_lost_.load()) exposure_->abandon();
    exposure_.reset();
  }
  stop_ptp_thread();  // before the camera goes; a status read in flight is at most one GVCP timeout
  ptp_locked_.store(false);
  std::lock_guard lock(mutex_);
  open_.store(false);
  if (st_->camera == nullptr) return;
  // The device's heartbeat thread outlives this close by seconds on the release thread below: a
  // CCP read of a restarted camera that nobody controls yet is "control-lost", which must reach
  // neither the next connection's flag nor a destroyed source (camera/README.md "Reopening").
  g_signal_handlers_disconnect_matched(st_->device, G_SIGNAL_MATCH_DATA, 0, 0, nullptr, nullptr, &control_lost_);
  const bool lost = control_lost_.load();
  if (!lost) arv_camera_stop_acquisition(st_->camera, nullptr);
  fold_stats();
  st_->buffers.clear();
  if (lost) {
    // A dead device's stream channel and control channel are released with GVCP retries that
    // take seconds: not on the capture thread, which reopens as soon as the camera answers. The
    // old pool goes with them (its stream may write into it until it is stopped).
    std::thread([camera = st_->camera, stream = st_->stream, pool = std::move(st_->pool)]() mutable {
      if (stream != nullptr) g_object_unref(stream);
      g_object_unref(camera);
      pool.reset();
    }).detach();
    st_->stream = nullptr;
    st_->camera = nullptr;
  } else {
    unref(st_->stream);  // frees its buffers (ours stay: the pool owns the memory)
    unref(st_->camera);
  }
  st_->device = nullptr;
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
  std::unique_lock lock(mutex_, until);
  std::unique_lock gl(*gc_mutex_, std::defer_lock);
  if (!lock.owns_lock() || !gl.try_lock_until(until)) {
    trigger_lock_busy_.fetch_add(1);
    return false;
  }
  if (st_->camera == nullptr || control_lost_.load()) return false;
  GError* err = nullptr;
  arv_camera_software_trigger(st_->camera, &err);
  if (err == nullptr) return true;
  g_error_free(err);
  return false;
}

// GigE Vision 1.x block ids run 1..65535 and wrap to 1 (0 is reserved): a step of more than one
// is frames the camera made that never came out of the stream (an underrun, a frame Aravis dropped).
// A step back or a huge one is a rebooted camera: no loss known, counting starts again.
void AravisSource::count_missing_frames(std::uint64_t id) noexcept {
  constexpr std::int64_t kWrap = 65535;
  constexpr std::int64_t kPlausibleGap = 1000;
  if (last_frame_id_ != 0 && id != 0) {
    std::int64_t d = static_cast<std::int64_t>(id) - static_cast<std::int64_t>(last_frame_id_);
    if (id <= 0xFFFF && last_frame_id_ <= 0xFFFF && d <= 0) d += kWrap;
    if (d > 1 && d <= kPlausibleGap) missing_frames_.fetch_add(static_cast<std::uint64_t>(d - 1));
  }
  last_frame_id_ = id;
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
  const Nanos real = vehicle_now_ns();
  const Nanos mono = monotonic_now_ns();
  count_missing_frames(arv_buffer_get_frame_id(b));
  const auto status = arv_buffer_get_status(b);
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
  return s;
}

}  // namespace sensor_rig::camera
