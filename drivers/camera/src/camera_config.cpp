#include "sensor_rig/drivers/camera/camera_config.hpp"

#include <arpa/inet.h>

#include <algorithm>
#include <cctype>
#include <filesystem>

namespace sensor_rig::drivers {

const char* to_string(CameraMockConfig::Kind k) noexcept {
  switch (k) {
    case CameraMockConfig::Kind::kNone: return "none";
    case CameraMockConfig::Kind::kGige: return "gige";
    case CameraMockConfig::Kind::kAravisInProcess: return "aravis-inprocess";
    case CameraMockConfig::Kind::kV4l2Fake: return "v4l2-fake";
  }
  return "?";
}

int CameraConfig::watchdog() const noexcept {
  if (watchdog_ms > 0) return watchdog_ms;
  // Three frame periods, at least 500 ms (a fresh stream's first frame). It follows the period: a
  // 1 Hz camera capped at 800 ms was reopened before every frame (issue 27 item 2).
  const double period_ms = source.frame_rate > 0 ? 1000.0 / source.frame_rate : 1000.0;
  return static_cast<int>(std::max(3.0 * period_ms, 500.0));
}

namespace {

CameraMockConfig parse_mock(const config::Node& n) {
  n.allow_keys({"kind", "lost_packets_per_thousand"});
  CameraMockConfig m;
  const auto kind = n.get_choice("kind", {"none", "gige", "aravis-inprocess", "v4l2-fake"}, "none");
  m.kind = kind == "gige"               ? CameraMockConfig::Kind::kGige
           : kind == "aravis-inprocess" ? CameraMockConfig::Kind::kAravisInProcess
           : kind == "v4l2-fake"        ? CameraMockConfig::Kind::kV4l2Fake
                                        : CameraMockConfig::Kind::kNone;
  m.lost_packets_per_thousand = static_cast<int>(n.get_int("lost_packets_per_thousand", 0, 1000, 0));
  return m;
}

// outputs: {image_color: none|bgr8|rgb8, compressed: bool, jpeg_quality: 1..100, queue_depth: 1..2}
CameraOutputsConfig parse_outputs(const config::Node& n, camera::PixelFormat format) {
  CameraOutputsConfig o;
  if (!n.expect_map()) return o;
  n.allow_keys({"image_color", "compressed", "jpeg_quality", "queue_depth"});
  const auto color = n.get_choice("image_color", {"none", "bgr8", "rgb8"}, "none");
  o.color = color != "none";
  o.color_order = color == "rgb8" ? camera::ColorOrder::kRgb : camera::ColorOrder::kBgr;
  o.compressed = n.get_bool("compressed", false);
  o.jpeg_quality = static_cast<int>(n.get_int("jpeg_quality", 1, 100, 90));
  o.queue_depth = static_cast<int>(n.get_int("queue_depth", 1, 2, 1));
  const auto& fi = camera::info(format);
  const std::string fmt = fi.genicam != nullptr ? fi.genicam : fi.v4l2_name != nullptr ? fi.v4l2_name : "?";
  if (o.color && !camera::is_bayer8(format))
    n.fail("image_color", "needs an 8-bit Bayer pixel_format (BayerRG8, BayerBG8, BayerGR8, BayerGB8), not " + fmt);
  const bool jpeg_input = camera::is_bayer8(format) || format == camera::PixelFormat::kMono8 ||
                          format == camera::PixelFormat::kRgb8 || format == camera::PixelFormat::kBgr8;
  if (o.compressed && !jpeg_input)
    n.fail("compressed", "JPEG needs an 8-bit Bayer, Mono8, RGB8 or BGR8 pixel_format, not " + fmt);
  return o;
}

// ptp: {enable: bool, timescale: tai|utc (tai), tai_utc_offset_s: 0..100 (37, only with tai)}
camera::PtpConfig parse_ptp(const config::Node& n, const std::string& backend) {
  camera::PtpConfig p;
  if (!n.expect_map()) return p;
  n.allow_keys({"enable", "timescale", "tai_utc_offset_s", "grandmaster"});
  p.enable = n.get_bool("enable", false);
  // Only a camera meant to be the grandmaster may stamp while Master (issue 27 item 7).
  p.grandmaster = n.get_bool("grandmaster", false);
  p.tai = n.get_choice("timescale", {"tai", "utc"}, "tai") == "tai";
  p.tai_utc_offset_s = static_cast<int>(n.get_int("tai_utc_offset_s", 0, 100, 37));
  if (!p.tai && n.has("tai_utc_offset_s")) n.fail("tai_utc_offset_s", "only with timescale: tai (a UTC camera needs no offset)");
  if (backend != "aravis") n.fail("", "PTP needs the aravis backend (a GigE camera)");
  return p;
}

// trigger: {mode: line, line: Line<N> (Line1), activation: RisingEdge|FallingEdge|AnyEdge|LevelHigh|LevelLow}
void parse_line_trigger(const config::Node& t, camera::SourceConfig& s) {
  s.trigger_line = t.get_string("line", "Line1");
  s.trigger_activation =
      t.get_choice("activation", {"RisingEdge", "FallingEdge", "AnyEdge", "LevelHigh", "LevelLow"}, "RisingEdge");
  const auto& line = s.trigger_line;
  const auto digit = [](char ch) { return std::isdigit(static_cast<unsigned char>(ch)) != 0; };
  const bool line_n = line.size() > 4 && line.rfind("Line", 0) == 0 && std::all_of(line.begin() + 4, line.end(), digit);
  if (t.has("line") && !line_n)
    t.fail("line", "'" + line + "' is not an I/O line: Line<N> as the camera's TriggerSource names it (Line0, Line1, ...)");
  if (s.trigger != camera::TriggerMode::kLine)
    for (const char* k : {"line", "activation"})
      if (t.has(k)) t.fail(k, "only with mode: line (a hardware trigger line)");
}

}  // namespace

CameraConfig parse_camera_config(const config::Node& n) {
  CameraConfig c;
  if (!n.expect_map()) return c;
  n.allow_keys({"name", "backend", "device", "pixel_format", "width", "height", "frame_rate", "calibration", "exposure_us",
                "gain_db", "features", "trigger", "packet_size", "packet_delay_ns", "socket_buffer_bytes", "packet_socket", "buffers",
                "frame_id", "realtime_priority", "watchdog_ms", "qos", "mock", "outputs", "ptp", "stamp_at", "readout_us",
                "gain_units_per_db"});
  c.name = n.get_string("name");
  for (char ch : c.name)
    if (!(std::isalnum(static_cast<unsigned char>(ch)) || ch == '_')) {
      n.fail("name", "'" + c.name + "' must be letters, digits and '_' (it becomes a ROS topic name)");
      break;
    }
  auto& s = c.source;
  s.backend = n.get_choice("backend", {"aravis", "v4l2"}, "aravis");
  s.device = n.get_string("device");
  const std::string fmt = n.get_string("pixel_format", s.backend == "v4l2" ? "YUYV" : "BayerRG8");
  if (const auto f = camera::parse_pixel_format(fmt); !f) {
    n.fail("pixel_format", "unknown pixel format '" + fmt + "' (" + s.backend + ": " + camera::pixel_format_names(s.backend) + ")");
  } else if (!camera::backend_supports(s.backend, *f)) {
    n.fail("pixel_format", "the " + s.backend + " backend cannot do '" + fmt + "' (" + camera::pixel_format_names(s.backend) + ")");
  } else {
    s.format = *f;
  }
  s.width = static_cast<std::uint32_t>(n.get_int("width", 16, 8192, 1920));
  s.height = static_cast<std::uint32_t>(n.get_int("height", 16, 8192, 1200));
  if (s.format == camera::PixelFormat::kYuv422Yuyv && s.width % 2 != 0) n.fail("width", "YUYV needs an even width");
  s.frame_rate = n.get_double("frame_rate", 0.1, 240.0, 10.0);
  s.exposure_us = n.get_double("exposure_us", 0.0, 1e7, 0.0);
  if (s.exposure_us * s.frame_rate > 1e6) n.fail("exposure_us", "longer than one frame period at frame_rate");
  s.gain_db = n.get_double("gain_db", -1.0, 48.0, -1.0);
  if (auto f = n.child("features")) {
    if (!f->yaml().IsMap()) {
      f->fail("", "must be a map of GenICam feature name -> value");
    } else {
      for (const auto& kv : f->yaml()) {
        const auto key = kv.first.as<std::string>();
        if (!kv.second.IsScalar()) {
          f->fail(key, "value must be a scalar");
          continue;
        }
        s.features.emplace_back(key, kv.second.as<std::string>());
      }
      if (s.backend != "aravis" && !s.features.empty()) f->fail("", "GenICam features need the aravis backend");
    }
  }
  if (auto t = n.child("trigger")) {
    t->allow_keys({"mode", "line", "activation", "group", "lidar", "azimuth_deg", "latency_us"});
    auto& lt = c.lidar_trigger;
    lt.lidar = t->get_string("lidar", "");
    // A LIDAR trigger is a software trigger: mode may be left out, any other mode is a mistake.
    const auto mode = t->get_choice("mode", {"free_run", "software", "line"}, lt.enabled() ? "software" : "free_run");
    s.trigger = mode == "software" ? camera::TriggerMode::kSoftware
                : mode == "line"   ? camera::TriggerMode::kLine
                                   : camera::TriggerMode::kFreeRun;
    parse_line_trigger(*t, s);
    c.trigger_group = t->get_string("group", "");
    if (s.trigger != camera::TriggerMode::kFreeRun && s.backend != "aravis")
      t->fail("mode", "trigger modes need the aravis backend (V4L2 cameras free-run)");
    if (!c.trigger_group.empty() && s.trigger != camera::TriggerMode::kSoftware)
      t->fail("group", "a trigger group needs mode: software");
    if (lt.enabled()) {
      if (!t->has("azimuth_deg")) t->fail("azimuth_deg", "required with lidar: the azimuth (degrees, LIDAR frame) to expose at");
      lt.azimuth_deg = t->get_double("azimuth_deg", 0.0, 360.0, 0.0);
      if (lt.azimuth_deg >= 360.0) t->fail("azimuth_deg", "must be in [0, 360)");
      lt.latency_us = t->get_double("latency_us", 0.0, 100'000.0, 0.0);
      if (s.trigger != camera::TriggerMode::kSoftware) t->fail("mode", "a LIDAR trigger needs mode: software");
      // With group: the whole group is fired by that crossing (rig checks its members agree).
    } else {
      for (const char* k : {"azimuth_deg", "latency_us"})
        if (t->has(k)) t->fail(k, "only with lidar: (a LIDAR-triggered camera)");
    }
  }
  s.packet_size = static_cast<int>(n.get_int("packet_size", 0, 16384, 0));
  if (s.packet_size != 0 && s.packet_size < 576) n.fail("packet_size", "0 (negotiate) or 576..16384");
  s.packet_delay_ns = n.get_int("packet_delay_ns", 0, 1'000'000'000, 0);
  // SPEC §8: below 4 MB most frames fail.
  s.socket_buffer_bytes = static_cast<int>(n.get_int("socket_buffer_bytes", 4 << 20, 1 << 30, 8 << 20));
  // Aravis' packet socket (a kernel ring, CAP_NET_RAW): off by default, since it receives nothing
  // from the fake as root (SPEC §8); a real camera may use it (issue 27 item 4).
  s.packet_socket = n.get_bool("packet_socket", false);
  s.buffers = static_cast<int>(n.get_int("buffers", 2, 64, 4));
  c.calibration = n.get_path("calibration", "");
  c.info = camera::uncalibrated(s.width, s.height);
  if (!c.calibration.empty()) {
    if (!std::filesystem::is_regular_file(c.calibration)) {
      n.fail("calibration", "file not found: " + c.calibration);
    } else {
      try {
        c.info = camera::load_calibration(c.calibration);
        if (const auto e = camera::size_mismatch(c.info, s.width, s.height); !e.empty()) n.fail("calibration", e);
      } catch (const camera::CalibrationError& e) {
        n.fail("calibration", e.what());
      }
    }
  }
  c.frame_id = n.get_string("frame_id", "camera_" + c.name);
  c.realtime_priority = static_cast<int>(n.get_int("realtime_priority", 0, 98, 0));
  c.watchdog_ms = static_cast<int>(n.get_int("watchdog_ms", 0, 60'000, 0));
  // V4L2 buffer stamps (camera/README.md "V4L2 stamps"): where the driver takes them, the readout.
  s.v4l2_stamp = n.get_choice("stamp_at", {"auto", "start", "end"}, "auto");
  s.readout_us = n.get_double("readout_us", 0.0, 1'000'000.0, 0.0);
  if (s.backend != "v4l2")
    for (const char* k : {"stamp_at", "readout_us"})
      if (n.has(k)) n.fail(k, "only for the v4l2 backend (a GigE camera reports its exposure start)");
  // V4L2_CID_GAIN has no unit: gain_db is converted with the driver's units per dB (from its minimum).
  s.v4l2_gain_units_per_db = n.get_double("gain_units_per_db", 0.0, 1e6, 0.0);
  if (s.backend != "v4l2" && n.has("gain_units_per_db"))
    n.fail("gain_units_per_db", "only for the v4l2 backend (GenICam Gain is in dB)");
  if (s.backend == "v4l2" && s.gain_db >= 0 && !(s.v4l2_gain_units_per_db > 0))
    n.fail("gain_db", "a V4L2 camera's gain has no unit: give gain_units_per_db (the driver's V4L2_CID_GAIN units per dB, "
                      "from its minimum as 0 dB)");
  if (auto q = n.child("qos")) c.qos = dds::QosSpec::from_config(*q, c.qos);
  if (auto m = n.child("mock")) c.mock = parse_mock(*m);
  if (auto o = n.child("outputs")) c.outputs = parse_outputs(*o, s.format);
  if (auto p = n.child("ptp")) s.ptp = parse_ptp(*p, s.backend);
  using K = CameraMockConfig::Kind;
  const bool aravis_mock = c.mock.kind == K::kGige || c.mock.kind == K::kAravisInProcess;
  if (aravis_mock && s.backend != "aravis") n.fail("mock", std::string("mock ") + to_string(c.mock.kind) + " needs backend: aravis");
  if (c.mock.kind == K::kV4l2Fake && s.backend != "v4l2") n.fail("mock", "mock v4l2-fake needs backend: v4l2");
  if (c.mock.kind == K::kGige) {
    in_addr a{};
    if (::inet_pton(AF_INET, s.device.c_str(), &a) != 1 || (ntohl(a.s_addr) >> 24) != 127)
      n.fail("device", "a gige mock runs on a loopback address (127.0.0.x), not '" + s.device + "'");
  }
  if (c.mock.lost_packets_per_thousand > 0 && c.mock.kind != K::kGige) n.fail("mock", "lost_packets_per_thousand needs kind: gige");
  if (s.backend == "v4l2" && c.mock.kind == K::kNone && s.device.rfind("/dev/", 0) != 0)
    n.fail("device", "a V4L2 device is a /dev/videoN path");
  return c;
}

}  // namespace sensor_rig::drivers
