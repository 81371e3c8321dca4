// Model name -> synthetic sensor (see synthetic_factory.hpp).
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"

#include <cmath>
#include <stdexcept>

#include "sensor_rig/lidar/hesai/calibration.hpp"
#include "sensor_rig/lidar/mock/phase_lock.hpp"
#include "sensor_rig/lidar/mock/synthetic_hesai.hpp"
#include "sensor_rig/lidar/mock/synthetic_ouster.hpp"
#include "sensor_rig/lidar/mock/synthetic_velodyne.hpp"
#include "sensor_rig/lidar/ouster/profile.hpp"
#include "sensor_rig/lidar/velodyne/calibration.hpp"
#include "sensor_rig/lidar/velodyne/model.hpp"

namespace sensor_rig::lidar::mock {
namespace {

constexpr std::string_view kModels[] = {"VLP-16", "VLP-32C", "HDL-32E", "OS-LEGACY", "OS", "Pandar40P", "PandarXT32"};
constexpr auto kDefaultOsProfile = ouster::Profile::kRng19Rfl8Sig16Nir16;

std::unique_ptr<SyntheticSensor> make_velodyne(const SyntheticOptions& o, velodyne::Model m, Scene scene) {
  SyntheticConfig c;
  c.model = m;
  c.rpm = o.rpm;
  c.return_mode = o.returns == ReturnSelection::kDual   ? velodyne::ReturnMode::kDual
                  : o.returns == ReturnSelection::kLast ? velodyne::ReturnMode::kLast
                                        : velodyne::ReturnMode::kStrongest;
  c.start_ns = o.start_ns;
  c.start_azimuth_deg = o.start_rotor_deg;
  try {
    if (!o.calibration_text.empty()) c.calibration = velodyne::parse_calibration(o.calibration_text, o.calibration_name);
    return std::make_unique<SyntheticVelodyne>(c, std::move(scene));
  } catch (const std::invalid_argument&) {
    throw;
  } catch (const std::exception& e) {  // CalibrationError
    throw std::invalid_argument(e.what());
  }
}

std::unique_ptr<SyntheticSensor> make_hesai(const SyntheticOptions& o, hesai::Model m, Scene scene) {
  SyntheticHesaiConfig c;
  c.model = m;
  c.rpm = o.rpm;
  c.return_mode = o.returns == ReturnSelection::kDual   ? hesai::ReturnMode::kLastStrongest
                  : o.returns == ReturnSelection::kLast ? hesai::ReturnMode::kLast
                                        : hesai::ReturnMode::kStrongest;
  c.start_ns = o.start_ns;
  c.start_azimuth_deg = o.start_rotor_deg;
  try {
    if (!o.calibration_text.empty()) {
      if (hesai::is_firetime_csv(o.calibration_text)) {
        c.firing_times = hesai::parse_firetime_csv(o.calibration_text, o.calibration_name, m);
      } else {
        c.calibration = hesai::parse_angle_csv(o.calibration_text, o.calibration_name, m);
      }
    }
  } catch (const std::exception& e) {  // DecoderConfigError naming file:line
    throw std::invalid_argument(e.what());
  }
  return std::make_unique<SyntheticHesai>(c, std::move(scene));
}

}  // namespace

std::string synthetic_model_names() {
  std::string s;
  for (const auto m : kModels) s += (s.empty() ? "" : ", ") + std::string(m);
  return s;
}

bool is_synthetic_model(std::string_view model) noexcept {
  for (const auto m : kModels)
    if (m == model) return true;
  return false;
}

bool is_ouster_model(std::string_view model) noexcept { return model == "OS-LEGACY" || model == "OS"; }

ouster::SensorMetadata synthetic_ouster_metadata(const SyntheticOptions& o) {
  if (!is_ouster_model(o.model)) throw std::invalid_argument("not an Ouster model: " + o.model);
  const bool legacy = o.model == "OS-LEGACY";
  if (!o.metadata_text.empty()) {
    ouster::SensorMetadata m;
    try {
      m = ouster::parse_metadata(o.metadata_text, o.metadata_name.empty() ? "metadata" : o.metadata_name);
    } catch (const std::exception& e) {
      throw std::invalid_argument(e.what());
    }
    if ((m.profile == ouster::Profile::kLegacy) != legacy) {
      throw std::invalid_argument(m.source + ": profile " + std::string(ouster::profile_spec(m.profile).name) +
                                  (legacy ? " is not LEGACY: use model OS" : " is LEGACY: use model OS-LEGACY"));
    }
    return m;
  }
  NominalOuster n;
  n.beams = o.ouster_beams;
  if (o.ouster_mode.empty()) {
    if (o.rpm != 600.0 && o.rpm != 1200.0)
      throw std::invalid_argument("Ouster lidar modes run at 10 or 20 Hz (600 or 1200 rpm), not " +
                                  std::to_string(o.rpm) + " rpm");
    n.lidar_mode = o.rpm == 600.0 ? "1024x10" : "1024x20";
  } else {
    n.lidar_mode = o.ouster_mode;
  }
  if (legacy) {
    if (!o.ouster_profile.empty() && o.ouster_profile != "LEGACY")
      throw std::invalid_argument("OS-LEGACY renders the LEGACY profile, not " + o.ouster_profile);
    n.profile = ouster::Profile::kLegacy;
  } else if (o.ouster_profile.empty()) {
    n.profile = kDefaultOsProfile;
  } else {
    const auto p = ouster::profile_from_name(o.ouster_profile);
    if (!p || *p == ouster::Profile::kLegacy) {
      throw std::invalid_argument("unknown or LEGACY profile '" + o.ouster_profile +
                                  "' for model OS (supported: " + ouster::profile_names() + ")");
    }
    n.profile = *p;
  }
  n.udp_port_lidar = o.ouster_udp_port;
  n.udp_port_imu = static_cast<std::uint16_t>(o.ouster_udp_port + 1);
  return nominal_ouster_metadata(n);
}

std::string synthetic_options_error(const SyntheticOptions& o) {
  try {
    (void)make_synthetic_sensor(o, Scene());  // an empty scene: construction only validates
    return {};
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
}

std::unique_ptr<SyntheticSensor> make_synthetic_sensor(const SyntheticOptions& o, Scene scene) {
  if (!is_synthetic_model(o.model))
    throw std::invalid_argument("unknown synthetic model '" + o.model + "' (supported: " + synthetic_model_names() + ")");
  std::unique_ptr<SyntheticSensor> s;
  if (const auto v = velodyne::model_from_name(o.model)) {
    s = make_velodyne(o, *v, std::move(scene));
  } else if (const auto h = hesai::model_from_name(o.model)) {
    s = make_hesai(o, *h, std::move(scene));
  } else {
    SyntheticOusterConfig c;
    c.metadata = synthetic_ouster_metadata(o);
    c.start_ns = o.start_ns;
    const int w = c.metadata.columns_per_frame, cpp = c.metadata.columns_per_packet;
    const auto col = static_cast<int>(std::lround(o.start_rotor_deg / 360.0 * w / cpp)) * cpp;
    c.start_column = ((col % w) + w) % w;
    if (o.boot != 0 && c.metadata.init_id != 0) c.metadata.init_id = (c.metadata.init_id + o.boot) & 0xFFFFFFU;
    c.imu_period_ns = o.ouster_imu_period_ns;
    s = std::make_unique<SyntheticOuster>(std::move(c), std::move(scene));
  }
  if (o.phase_lock_deg) (void)phase_locked_start_ns(*s, o.start_ns, *o.phase_lock_deg);  // throws if it cannot lock
  return s;
}

}  // namespace sensor_rig::lidar::mock
