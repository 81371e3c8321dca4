// AravisSource's connection: open (probe, device, configuration, stream), reopen and close
// (camera/README.md "Dead cameras, reopening, loss" and "Reopening a live camera"). A camera that
// does not answer costs its own caller's thread a short probe, never a lock another camera's open
// or a trigger needs (issue 27 item 1).
#include <arv.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "aravis_internal.hpp"
#include "exposure_watcher.hpp"
#include "gvcp_probe.hpp"
#include "sensor_rig/common/log.hpp"
#include "socket_buffer.hpp"

namespace sensor_rig::camera {

using detail::feature_text;
using detail::take_error;
using detail::unref;

// Aravis 0.8 parses each device's GenICam XML while opening it, and opening from several threads at
// once corrupts its DOM (GLib criticals, and a SIGFPE seen in `rig demo` with seven cameras opening
// together): one open at a time in the process. Held only while Aravis builds the device (its XML)
// of a camera that just answered the GVCP probe: never through a dead camera's GVCP timeouts.
namespace {
// How long close() waits for a trigger's GVCP write in flight on a camera that still answered its
// probe (a healthy write takes well under a millisecond).
constexpr int kCloseTriggerWaitMs = 200;

// The cameras this process has open, by vendor, model and serial: the same camera given twice (by
// address and by serial, or by two addresses) passed the config's check, which compares the
// strings, and the second open stopped the first one's acquisition (issue 27 item 13).
struct OpenCamera {
  const void* owner;
  std::string device;
};
std::mutex open_cameras_mutex;
std::map<std::string, OpenCamera>& open_cameras() {
  static std::map<std::string, OpenCamera> m;
  return m;
}

// A camera at an address that answered the probe, opened by address: no discovery, no
// arv_open_device (whose camera_locate and device-list update ran under Aravis' system mutex:
// ~2.5 s for a dead address, measured with Aravis 0.8.26 on loopback).
ArvDevice* open_gv_device(const std::string& interface_address, const std::string& device) {
  GInetAddress* iface = g_inet_address_new_from_string(interface_address.c_str());
  GInetAddress* addr = g_inet_address_new_from_string(device.c_str());
  GError* err = nullptr;
  ArvDevice* d = iface != nullptr && addr != nullptr ? arv_gv_device_new(iface, addr, &err) : nullptr;
  if (iface != nullptr) g_object_unref(iface);
  if (addr != nullptr) g_object_unref(addr);
  if (d == nullptr) throw CameraError("aravis " + device + ": " + (err != nullptr ? take_error(err) : std::string("bad address")));
  return d;
}
// The camera's IPv4 address as its GigE device has it ("" when not known).
std::string device_address(ArvDevice* device) {
  GSocketAddress* sa = arv_gv_device_get_device_address(ARV_GV_DEVICE(device));  // the device's
  if (sa == nullptr || !G_IS_INET_SOCKET_ADDRESS(sa)) return {};
  gchar* text = g_inet_address_to_string(g_inet_socket_address_get_address(G_INET_SOCKET_ADDRESS(sa)));
  std::string out = text != nullptr ? text : "";
  g_free(text);
  return detail::is_ipv4_address(out) ? out : std::string();
}
}  // namespace

void* open_aravis_network_device(const std::string& device) {
  // An address is probed, then opened by address: a dead camera costs the probe (0.3 s), not
  // Aravis' GVCP retries and discovery.
  if (detail::is_ipv4_address(device)) return open_gv_device(detail::probe_gvcp(device), device);
  GError* err = nullptr;
  ArvDevice* d = arv_open_device(device.c_str(), &err);
  if (d != nullptr) return d;
  const std::string first = take_error(err);
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
  reopened_ = true;  // its ids may go on (counted) or have restarted (count_missing_frames tells)
  last_exposure_ns_.store(0);
  AravisDetails details;
  try {
    {
      // The network path probes an address before the lock (throws CameraError when the camera
      // does not answer): a dead camera's attempts never hold the lock the other cameras' opens need.
      std::string iface;
      if (network_ && detail::is_ipv4_address(cfg_.device)) iface = detail::probe_gvcp(cfg_.device);
      std::lock_guard one_open_at_a_time(detail::genicam_parse_mutex());  // GenICam XML parsing only
      auto* device = !iface.empty() ? open_gv_device(iface, cfg_.device)
                                    : static_cast<ArvDevice*>(opener_(cfg_.device));  // throws CameraError
      GError* err = nullptr;
      fresh->camera = arv_camera_new_with_device(device, &err);
      g_object_unref(device);  // the camera holds its own reference
      if (fresh->camera == nullptr) throw CameraError("aravis " + cfg_.device + ": " + take_error(err));
    }
    fresh->device = arv_camera_get_device(fresh->camera);
    fresh->gv = arv_camera_is_gv_device(fresh->camera) != FALSE;
    if (fresh->gv) fresh->address = device_address(fresh->device);
    g_signal_connect_data(fresh->device, "control-lost", reinterpret_cast<GCallback>(&detail::on_control_lost), &control_lost_,
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
    release_identity();
    if (fresh->stream != nullptr) arv_stream_set_emit_signals(fresh->stream, FALSE);
    if (fresh->device != nullptr)
      g_signal_handlers_disconnect_matched(fresh->device, G_SIGNAL_MATCH_DATA, 0, 0, nullptr, nullptr, &control_lost_);
    unref(fresh->stream);
    unref(fresh->camera);
    throw;
  }
  {
    // A GenICam lock of its own: a trigger still in a GVCP write to the previous connection (a
    // camera that died, ~2.4 s of Aravis retries) holds that one's, not this one's.
    std::lock_guard lock(mutex_);
    gc_mutex_ = std::make_shared<std::timed_mutex>();
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
void AravisSource::claim_identity(const AravisDetails& details) {
  if (details.serial.empty()) return;  // nothing to tell two cameras apart by
  const std::string identity = details.vendor + "/" + details.model + "/" + details.serial;
  std::lock_guard lock(open_cameras_mutex);
  auto [it, fresh] = open_cameras().try_emplace(identity, OpenCamera{this, cfg_.device});
  if (!fresh && it->second.owner != this)
    throw CameraError("aravis " + cfg_.device + ": the same camera (" + details.vendor + " " + details.model + ", serial " +
                      details.serial + ") is already open as device '" + it->second.device +
                      "': one camera in two config entries; the second is refused");
  claimed_ = identity;
}

void AravisSource::release_identity() noexcept {
  if (claimed_.empty()) return;
  std::lock_guard lock(open_cameras_mutex);
  const auto it = open_cameras().find(claimed_);
  if (it != open_cameras().end() && it->second.owner == this) open_cameras().erase(it);
  claimed_.clear();
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
  claim_identity(details);  // before anything is written: a second open must not stop the first's stream
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
  st.chunks.set_part_layout(dev);                         // multipart: where the chunk part holds them
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
  // A GigE camera that stopped answering and is not known lost yet (the rig stopped within the
  // watchdog's wait after a cable was pulled): 2 x 100 ms of GVCP say so, and nothing below waits
  // for its GVCP timeouts (the exposure read, AcquisitionStop, the stream's and the control
  // channel's release took 12.5 s: issue 27 item 1, camera_isolation_test).
  if (open_.load() && !control_lost_.load() && !st_->address.empty() &&
      !detail::answers_gvcp(st_->address, detail::GvcpProbe{2, 100}))
    control_lost_.store(true);
  if (exposure_) {  // a read on a dead camera takes seconds: not waited for
    if (control_lost_.load()) exposure_->abandon();
    exposure_.reset();
  }
  stop_ptp_thread();  // before the camera goes; a status read in flight is at most one GVCP timeout
  ptp_locked_.store(false);
  std::lock_guard lock(mutex_);
  open_.store(false);
  release_identity();
  if (st_->camera == nullptr) return;
  // The device's heartbeat thread outlives this close by seconds on the release thread below: a
  // CCP read of a restarted camera that nobody controls yet is "control-lost", which must reach
  // neither the next connection's flag nor a destroyed source (camera/README.md "Reopening").
  g_signal_handlers_disconnect_matched(st_->device, G_SIGNAL_MATCH_DATA, 0, 0, nullptr, nullptr, &control_lost_);
  // A trigger's GVCP write may be in flight (trigger() holds only the GenICam lock for it): a
  // camera that still answers ends it within a few ms; one whose write is in its retries is lost.
  std::unique_lock gl(*gc_mutex_, std::defer_lock);
  if (!control_lost_.load() && !gl.try_lock_for(std::chrono::milliseconds(kCloseTriggerWaitMs))) control_lost_.store(true);
  const bool lost = control_lost_.load();
  if (!lost) arv_camera_stop_acquisition(st_->camera, nullptr);
  count_undelivered(st_->stream);
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

}  // namespace sensor_rig::camera
