// The synthetic Ouster's metadata: a nominal OS-1, and SensorMetadata -> the JSON the sensor serves
// (flat FW 2.x layout for LEGACY, the nested FW 2.4+ layout for eUDP profiles).
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

#include "sensor_rig/lidar/mock/synthetic_ouster.hpp"

namespace sensor_rig::lidar::mock {
namespace {

using OrderedJson = nlohmann::ordered_json;

constexpr const char* kModes[] = {"512x10", "1024x10", "2048x10", "512x20", "1024x20", "4096x5"};
constexpr double kHalfFovDeg = 16.6;                                       // OS-1: 33.2° vertical
constexpr double kStaggerDeg[4] = {4.23, 1.41, -1.41, -4.23};              // 4-column beam stagger
constexpr double kOriginToBeamMm = 15.806;                                 // OS-1
constexpr ouster::Mat4 kOs1LidarToSensor{-1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1, 36.18, 0, 0, 0, 1};
constexpr std::uint32_t kInitId = 0x5E1D42;

double round3(double v) { return std::round(v * 1000.0) / 1000.0; }

OrderedJson matrix(const ouster::Mat4& m) {
  OrderedJson a = OrderedJson::array();
  for (const double v : m) a.push_back(v);
  return a;
}

bool only_origin_offset(const ouster::Mat4& b) {
  for (std::size_t i = 0; i < b.size(); ++i)
    if (i != 3 && b[i] != ouster::kIdentity[i]) return false;
  return true;
}

OrderedJson data_format(const ouster::SensorMetadata& m) {
  OrderedJson df;
  df["pixels_per_column"] = m.pixels_per_column;
  df["columns_per_packet"] = m.columns_per_packet;
  df["columns_per_frame"] = m.columns_per_frame;
  df["column_window"] = {m.column_window_first, m.column_window_last};
  df["pixel_shift_by_row"] = m.pixel_shift_by_row;
  if (m.profile != ouster::Profile::kLegacy) {
    df["udp_profile_lidar"] = std::string(ouster::profile_spec(m.profile).name);
    if (m.header_type != ouster::default_header_type(m.profile))
      df["header_type"] = m.header_type == ouster::HeaderType::kFusa ? "FUSA" : "STANDARD";
  }
  return df;
}

void beams(OrderedJson& o, const ouster::SensorMetadata& m) {
  o["beam_altitude_angles"] = m.beam_altitude_deg;
  o["beam_azimuth_angles"] = m.beam_azimuth_deg;
  if (only_origin_offset(m.beam_to_lidar)) {
    o["lidar_origin_to_beam_origin_mm"] = m.beam_to_lidar[3];
  } else {
    o["beam_to_lidar_transform"] = matrix(m.beam_to_lidar);
  }
}

const char* return_order(ouster::ReturnOrder r) {
  switch (r) {
    case ouster::ReturnOrder::kFarthestFirst:
      return "FARTHEST_TO_NEAREST";
    case ouster::ReturnOrder::kNearestFirst:
      return "NEAREST_TO_FARTHEST";
    case ouster::ReturnOrder::kStrongestFirst:
      break;
  }
  return "STRONGEST_TO_WEAKEST";
}

}  // namespace

bool is_ouster_lidar_mode(const std::string& mode) noexcept {
  for (const char* m : kModes)
    if (mode == m) return true;
  return false;
}

ouster::SensorMetadata nominal_ouster_metadata(const NominalOuster& n) {
  if (n.beams != 16 && n.beams != 32 && n.beams != 64 && n.beams != 128)
    throw std::invalid_argument("Ouster beams must be 16, 32, 64 or 128, not " + std::to_string(n.beams));
  if (!is_ouster_lidar_mode(n.lidar_mode)) {
    std::string all;
    for (const char* m : kModes) all += (all.empty() ? "" : ", ") + std::string(m);
    throw std::invalid_argument("Ouster lidar mode '" + n.lidar_mode + "' is not one of " + all);
  }
  const auto x = n.lidar_mode.find('x');
  ouster::SensorMetadata m;
  m.source = "synthetic OS-1-" + std::to_string(n.beams);
  m.nested_format = n.profile != ouster::Profile::kLegacy;
  m.prod_line = "OS-1-" + std::to_string(n.beams) + "-U0";
  m.prod_sn = "992300000001";
  m.fw_rev = m.nested_format ? "v2.5.2" : "v2.1.1";
  m.lidar_mode = n.lidar_mode;
  m.columns_per_frame = std::stoi(n.lidar_mode.substr(0, x));
  m.frames_per_second = std::stod(n.lidar_mode.substr(x + 1));
  m.init_id = m.nested_format ? kInitId : 0;
  m.udp_port_lidar = n.udp_port_lidar;
  m.udp_port_imu = n.udp_port_imu;
  m.profile = n.profile;
  m.header_type = ouster::default_header_type(n.profile);
  m.pixels_per_column = n.beams;
  m.columns_per_packet = 16;
  m.column_window_first = 0;
  m.column_window_last = m.columns_per_frame - 1;
  const double step = 2.0 * kHalfFovDeg / (n.beams - 1);
  for (int r = 0; r < n.beams; ++r) {
    m.beam_altitude_deg.push_back(round3(kHalfFovDeg - step * r));
    m.beam_azimuth_deg.push_back(kStaggerDeg[r % 4]);
    // Destaggering: a beam looking further left (larger azimuth) sees a column's direction later.
    m.pixel_shift_by_row.push_back(static_cast<int>(
        std::lround((kStaggerDeg[r % 4] - kStaggerDeg[3]) * m.columns_per_frame / 360.0)));
  }
  m.beam_to_lidar = ouster::kIdentity;
  m.beam_to_lidar[3] = kOriginToBeamMm;
  m.lidar_to_sensor = kOs1LidarToSensor;
  (void)m.layout();  // the packet fits (it does for every beam count and mode above)
  return m;
}

std::string metadata_json(const ouster::SensorMetadata& m) {
  OrderedJson o;
  if (!m.nested_format) {
    o["prod_line"] = m.prod_line;
    o["prod_sn"] = m.prod_sn;
    o["build_rev"] = m.fw_rev;
    o["hostname"] = "sensor-rig-synthetic";
    o["status"] = "RUNNING";
    o["lidar_mode"] = m.lidar_mode;
    if (m.init_id != 0) o["initialization_id"] = m.init_id;
    o["udp_port_lidar"] = m.udp_port_lidar;
    o["udp_port_imu"] = m.udp_port_imu;
    beams(o, m);
    o["lidar_to_sensor_transform"] = matrix(m.lidar_to_sensor);
    o["data_format"] = data_format(m);
    return o.dump(4) + "\n";
  }
  OrderedJson info;
  info["prod_line"] = m.prod_line;
  info["prod_sn"] = m.prod_sn;
  info["build_rev"] = m.fw_rev;
  if (m.init_id != 0) info["initialization_id"] = m.init_id;
  info["status"] = "RUNNING";
  OrderedJson cfg;
  cfg["lidar_mode"] = m.lidar_mode;
  cfg["udp_port_lidar"] = m.udp_port_lidar;
  cfg["udp_port_imu"] = m.udp_port_imu;
  cfg["udp_profile_lidar"] = std::string(ouster::profile_spec(m.profile).name);
  cfg["return_order"] = return_order(m.return_order);
  OrderedJson bi;
  beams(bi, m);
  o["sensor_info"] = info;
  o["config_params"] = cfg;
  o["beam_intrinsics"] = bi;
  o["lidar_intrinsics"] = {{"lidar_to_sensor_transform", matrix(m.lidar_to_sensor)}};
  o["lidar_data_format"] = data_format(m);
  return o.dump(4) + "\n";
}

}  // namespace sensor_rig::lidar::mock
