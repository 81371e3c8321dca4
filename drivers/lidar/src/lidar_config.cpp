#include "sensor_rig/drivers/lidar/lidar_config.hpp"

#include <arpa/inet.h>
#include <net/if.h>

#include <cmath>
#include <filesystem>

#include "sensor_rig/lidar/decoder_files.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"

namespace sensor_rig::drivers {
namespace {

// A split recording's folder (`rig record --split-*`): metadata.yaml or MCAP files in it. Checked
// roughly here; the replay (rig/src/recording_files.hpp) orders its files and names what is wrong
// with one.
bool is_split_recording(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_directory(path, ec)) return false;
  for (const auto& e : std::filesystem::directory_iterator(path, ec))
    if (e.path().filename() == "metadata.yaml" || e.path().extension() == ".mcap") return true;
  return false;
}

LidarMockConfig parse_mock(const config::Node& n) {
  n.allow_keys({"kind", "pcap", "file", "topic", "delay", "rate", "loop", "rpm", "phase_deg", "drop_rate", "corrupt_rate"});
  LidarMockConfig m;
  const auto kind = n.get_choice("kind", {"none", "synthetic", "replay", "mcap"}, "none");
  m.kind = kind == "synthetic" ? LidarMockConfig::Kind::kSynthetic
           : kind == "replay"  ? LidarMockConfig::Kind::kReplay
           : kind == "mcap"    ? LidarMockConfig::Kind::kMcap
                               : LidarMockConfig::Kind::kNone;
  const bool mcap = m.kind == LidarMockConfig::Kind::kMcap;
  m.pcap = n.get_path("pcap", "");
  if (m.kind == LidarMockConfig::Kind::kReplay && m.pcap.empty()) n.fail("pcap", "replay mock needs a pcap file");
  if (!m.pcap.empty() && !std::filesystem::exists(m.pcap)) n.fail("pcap", "file not found: " + m.pcap);
  if (!m.pcap.empty() && mcap) n.fail("pcap", "an mcap mock reads file: (a recording), not pcap:");
  m.file = n.get_path("file", "");
  if (mcap && m.file.empty())
    n.fail("kind", "an mcap mock needs file: a recording made with rig record --raw (its file or split folder)");
  if (!mcap && n.has("file")) n.fail("file", "only used with kind: mcap");
  if (!m.file.empty() && !std::filesystem::is_regular_file(m.file) && !is_split_recording(m.file))
    n.fail("file", std::filesystem::is_directory(m.file)
                       ? "'" + m.file + "' is a folder without a split recording (no metadata.yaml, no .mcap file)"
                       : "file not found: " + m.file);
  if (n.has("topic")) {
    m.topic = n.get_string("topic");
    if (!mcap) n.fail("topic", "only used with kind: mcap");
    else if (m.topic.rfind("/sensors/lidar/", 0) != 0 || !m.topic.ends_with("/packets"))
      n.fail("topic", "'" + m.topic + "' is not a raw LIDAR channel (/sensors/lidar/NAME/packets)");
  }
  if (n.has("delay") && !mcap) n.fail("delay", "only used with kind: mcap");
  m.delay_s = n.get_double("delay", 0.0, 60.0, 1.0);
  m.rate = n.get_double("rate", 0.01, 100.0, 1.0);
  m.loop = n.get_bool("loop", !mcap);  // a recorded drive plays once, as rig play does
  m.rpm = static_cast<int>(n.get_int("rpm", 300, 1200, 600));
  if (n.has("phase_deg")) {
    m.phase_deg = n.get_double("phase_deg", 0.0, 359.999, 0.0);
    if (m.kind != LidarMockConfig::Kind::kSynthetic) n.fail("phase_deg", "applies to a synthetic mock (a capture keeps its own phase)");
  }
  m.drop_rate = n.get_double("drop_rate", 0.0, 1.0, 0.0);
  m.corrupt_rate = n.get_double("corrupt_rate", 0.0, 1.0, 0.0);
  return m;
}

LidarRecordConfig parse_record(const config::Node& n) {
  LidarRecordConfig r;
  if (!n.expect_map()) return r;
  n.allow_keys({"directory", "max_file_mb", "max_file_s", "max_files", "queue_mb"});
  r.directory = n.get_path("directory");
  if (r.directory.empty()) n.fail("directory", "must name a directory");
  if (std::filesystem::exists(r.directory) && !std::filesystem::is_directory(r.directory))
    n.fail("directory", "'" + r.directory + "' exists and is not a directory");
  r.max_file_mb = n.get_double("max_file_mb", 1.0, 1024.0 * 1024.0, 256.0);
  r.max_file_s = n.get_double("max_file_s", 0.0, 86400.0, 60.0);
  r.max_files = static_cast<int>(n.get_int("max_files", 1, 100000, 10));
  r.queue_mb = n.get_double("queue_mb", 1.0, 4096.0, 16.0);
  return r;
}

// Builds the decoder the driver will build: a calibration or metadata file made for another model
// (or malformed) is an error at its key now, not a driver failing after `rig up` started the mocks.
void check_decoder_files(const config::Node& n, const LidarConfig& l) {
  const auto* model = lidar::find_model(l.model);
  if (model == nullptr || model->make == nullptr || (l.calibration.empty() && l.metadata.empty())) return;
  if (model->needs_metadata && l.metadata.empty()) return;  // synthetic: `rig up` writes it
  const char* key = l.calibration.empty() ? "metadata" : "calibration";
  const std::string& file = l.calibration.empty() ? l.metadata : l.calibration;
  if (!std::filesystem::is_regular_file(file)) return;  // reported as not found
  if (!l.metadata.empty() && !std::filesystem::is_regular_file(l.metadata)) return;  // reported as not found
  try {
    (void)lidar::make_decoder(decoder_options(l));
  } catch (const std::exception& e) {  // DecoderConfigError, or a file that cannot be read
    n.fail(key, e.what());
  }
}

// source / interface / sensor_address / ring_retire_ms. Whether the interface exists is the driver's to say at
// start (a USB NIC may come later than the config check); the name's form is checked here.
void parse_source(const config::Node& n, LidarConfig& l) {
  l.source = n.get_enum<LidarSource>("source", {{"udp", LidarSource::kUdp}, {"packet", LidarSource::kPacket}},
                                     LidarSource::kUdp);
  const bool packet = l.source == LidarSource::kPacket;
  if (n.has("interface")) {
    l.interface = n.get_string("interface");
    if (!packet) {
      n.fail("interface", "only used with source: packet (the UDP source binds host:port)");
    } else if (l.interface.empty() || l.interface.size() >= IF_NAMESIZE ||
               l.interface.find_first_of("/ \t:") != std::string::npos) {
      n.fail("interface", "'" + l.interface + "' is not a network interface name");
    }
  } else if (packet) {
    n.fail("source", "source: packet needs interface: <ifname> (the interface the sensor is on)");
  }
  if (n.has("ring_retire_ms")) {
    l.ring_retire_ms = static_cast<int>(n.get_int("ring_retire_ms", 1, 100));
    if (!packet) n.fail("ring_retire_ms", "only used with source: packet");
  }
  if (n.has("sensor_address")) {
    l.sensor_address = n.get_string("sensor_address");
    in_addr a{};
    if (!packet) {
      n.fail("sensor_address", "only used with source: packet (it selects the sensor's packets on the interface)");
    } else if (::inet_pton(AF_INET, l.sensor_address.c_str(), &a) != 1) {
      n.fail("sensor_address", "'" + l.sensor_address + "' is not an IPv4 address");
    }
  }
}

}  // namespace

LidarConfig parse_lidar_config(const config::Node& n) {
  LidarConfig l;
  if (!n.expect_map()) return l;
  n.allow_keys({"name", "model", "host", "port", "position_port", "imu_port", "receive_buffer_bytes", "source",
                "interface", "sensor_address", "ring_retire_ms", "calibration",
                "metadata", "returns", "min_range", "max_range", "cut_angle", "fov", "azimuth", "rpm", "time_source", "hour_source", "clock_correction",
                "frame_id", "extrinsics", "realtime_priority", "qos", "mock", "record"});
  l.name = n.get_string("name");
  for (char c : l.name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) {
      n.fail("name", "'" + l.name + "' must be letters, digits and '_' (it becomes a ROS topic name)");
      break;
    }
  l.model = n.get_string("model");
  if (const auto* m = lidar::find_model(l.model); m == nullptr || m->make == nullptr)
    n.fail("model", "'" + l.model + "' is not a supported model (supported: " + lidar::implemented_model_names() + ")");
  l.host = n.get_string("host", "127.0.0.1");
  l.port = static_cast<int>(n.get_int("port", 1, 65535));
  l.position_port = static_cast<int>(n.get_int("position_port", 0, 65535, 0));
  // The second port: Velodyne position packets (position_port), Ouster IMU packets (imu_port).
  if (n.has("imu_port")) {
    const auto imu_port = static_cast<int>(n.get_int("imu_port", 0, 65535, 0));
    if (!lidar::mock::is_ouster_model(l.model)) {
      n.fail("imu_port", "only Ouster sensors send IMU packets (model " + l.model + ")");
    } else if (l.position_port != 0) {
      n.fail("imu_port", "give imu_port (Ouster) or position_port (Velodyne), not both");
    } else {
      l.position_port = imu_port;
    }
  }
  l.receive_buffer_bytes = static_cast<int>(n.get_int("receive_buffer_bytes", 0, 1 << 30, 8 << 20));
  parse_source(n, l);
  l.calibration = n.get_path("calibration", "");
  if (!l.calibration.empty() && !std::filesystem::exists(l.calibration))
    n.fail("calibration", "file not found: " + l.calibration);
  l.metadata = n.get_path("metadata", "");
  if (!l.metadata.empty() && !std::filesystem::exists(l.metadata)) n.fail("metadata", "file not found: " + l.metadata);
  l.returns = n.get_enum<lidar::ReturnSelection>(
      "returns", {{"strongest", lidar::ReturnSelection::kStrongest}, {"last", lidar::ReturnSelection::kLast},
                  {"dual", lidar::ReturnSelection::kDual}},
      lidar::ReturnSelection::kStrongest);
  l.min_range_m = n.get_double("min_range", 0.0, 10.0, 0.4);
  l.max_range_m = n.get_double("max_range", 1.0, 1000.0, 200.0);
  if (l.min_range_m >= l.max_range_m) n.fail("max_range", "must be greater than min_range");
  l.cut_angle_deg = n.get_double("cut_angle", 0.0, 359.99, 0.0);
  if (auto f = n.child("fov")) {  // the sensor's own FOV setting: only gaps inside it are missing packets
    if (f->expect_map()) {
      f->allow_keys({"start", "end"});
      l.fov_start_deg = f->get_double("start", 0.0, 360.0);
      l.fov_end_deg = f->get_double("end", 0.0, 360.0);
      // start == end reads as a full turn to the decoder; written other than 0..360 it is a typo.
      const bool same = std::lround(l.fov_start_deg * 100) % 36000 == std::lround(l.fov_end_deg * 100) % 36000;
      if (same && !(l.fov_start_deg == 0.0 && l.fov_end_deg == 360.0))
        f->fail("end", "equals start: a full turn is {start: 0, end: 360}");
    }
    if (lidar::mock::is_ouster_model(l.model))
      n.fail("fov", "Ouster: the azimuth window is the sensor's own (its metadata), not a config key");
  }
  const auto* entry = lidar::find_model(l.model);
  if (n.has("azimuth") && entry != nullptr && entry->vendor != "velodyne")
    n.fail("azimuth", "only Velodyne models interpolate azimuth per laser (model " + l.model + ")");
  l.azimuth = n.get_enum<lidar::AzimuthInterpolation>(
      "azimuth", {{"per-laser", lidar::AzimuthInterpolation::kPerLaser},
                  {"per-sequence", lidar::AzimuthInterpolation::kPerSequence}},
      lidar::AzimuthInterpolation::kPerLaser);
  if (n.has("rpm")) {
    l.rpm = static_cast<int>(n.get_int("rpm", kSlowestRpm, 1200, 600));
    if (lidar::mock::is_ouster_model(l.model))
      n.fail("rpm", "Ouster: the rotation is the lidar_mode of its metadata (e.g. 1024x10), not a config key");
  }
  using timesync::Correction;
  using timesync::HourSource;
  using timesync::TimeSource;
  l.time_source = n.get_enum<TimeSource>("time_source", {{"sensor", TimeSource::kSensor}, {"host", TimeSource::kHost}},
                                         TimeSource::kHost);
  l.hour_source = n.get_enum<HourSource>("hour_source", {{"gprmc", HourSource::kGprmc}, {"host", HourSource::kHost}},
                                         HourSource::kGprmc);
  l.clock_correction = n.get_enum<Correction>(
      "clock_correction", {{"auto", Correction::kAuto}, {"always", Correction::kAlways}, {"never", Correction::kNever}},
      Correction::kAuto);
  l.frame_id = n.get_string("frame_id", "lidar_" + l.name);
  if (auto e = n.child("extrinsics")) l.extrinsics = parse_extrinsics(*e);
  l.realtime_priority = static_cast<int>(n.get_int("realtime_priority", 0, 98, 0));
  if (auto q = n.child("qos")) l.qos = dds::QosSpec::from_config(*q, l.qos);
  if (auto m = n.child("mock")) {
    l.mock = parse_mock(*m);
    // One speed: the sensor's `rpm` is the mock's unless the mock says its own, which must agree.
    if (l.rpm > 0 && l.mock.kind == LidarMockConfig::Kind::kSynthetic) {
      if (!m->has("rpm")) l.mock.rpm = l.rpm;
      else if (l.mock.rpm != l.rpm)
        m->fail("rpm", "the synthetic sensor turns at " + std::to_string(l.mock.rpm) + " rpm but the LIDAR's rpm is " +
                           std::to_string(l.rpm) + ": give one of them");
    }
  }
  if (l.mock.kind == LidarMockConfig::Kind::kMcap && l.mock.topic.empty()) l.mock.topic = "/sensors/lidar/" + l.name + "/packets";
  if (auto r = n.child("record")) l.record = parse_record(*r);
  check_decoder_files(n, l);
  const bool synthetic = l.mock.kind == LidarMockConfig::Kind::kSynthetic;
  // A synthetic Ouster without metadata: `rig up` writes the mock's own metadata for the driver.
  if (const auto* m = lidar::find_model(l.model); m != nullptr && m->needs_metadata && l.metadata.empty() && !synthetic)
    n.fail("metadata", "model " + l.model + " needs its sensor metadata JSON (or mock: {kind: synthetic})");
  // (A synthetic Ouster with metadata renders the sensor the file describes: nothing to check here.)
  if (synthetic && lidar::find_model(l.model) != nullptr && !(lidar::mock::is_ouster_model(l.model) && !l.metadata.empty())) {
    if (!lidar::mock::is_synthetic_model(l.model)) {
      n.fail("mock", "no synthetic sensor for model " + l.model + " (synthetic: " + lidar::mock::synthetic_model_names() + ")");
    } else {
      if (const auto e = lidar::mock::synthetic_options_error(synthetic_mock_options(l)); !e.empty()) n.fail("mock", e);
    }
  }
  return l;
}

int sizing_rpm(const LidarConfig& c) noexcept {
  if (c.mock.kind == LidarMockConfig::Kind::kSynthetic && c.mock.rpm > 0) return c.mock.rpm;
  return c.rpm > 0 ? c.rpm : kSlowestRpm;
}

lidar::mock::SyntheticOptions synthetic_mock_options(const LidarConfig& c) {
  lidar::mock::SyntheticOptions o;
  o.model = c.model;
  o.rpm = c.mock.rpm;
  o.phase_lock_deg = c.mock.phase_deg;
  o.ouster_udp_port = static_cast<std::uint16_t>(c.port);
  return o;
}

lidar::DecoderOptions decoder_options(const LidarConfig& c) {
  lidar::DecoderOptions d;
  d.model = c.model;
  try {
    lidar::apply_decoder_files(lidar::read_decoder_files(c.calibration, c.metadata), d);
  } catch (const lidar::DecoderFileError& e) {
    throw std::runtime_error(e.what());
  }
  d.returns = c.returns;
  d.min_range_m = c.min_range_m;
  d.max_range_m = c.max_range_m;
  d.cut_angle_deg = c.cut_angle_deg;
  d.fov_start_deg = c.fov_start_deg;
  d.fov_end_deg = c.fov_end_deg;
  d.azimuth = c.azimuth;
  return d;
}

}  // namespace sensor_rig::drivers
