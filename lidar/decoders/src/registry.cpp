// The model registry: one row per model SPEC §7 names. A vendor's decoder plugs in by its factory.
#include <string>

#include "sensor_rig/lidar/hesai/scan_decoder.hpp"
#include "sensor_rig/lidar/ouster/scan_decoder.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"
#include "velodyne_scan_decoder.hpp"

namespace sensor_rig::lidar {
namespace {

// Rows with a null factory are named by the SPEC but not implemented yet.
constexpr ModelEntry kModels[] = {
    {"VLP-16", "velodyne", 2368, false, &make_velodyne_decoder},
    {"VLP-32C", "velodyne", 2368, false, &make_velodyne_decoder},
    {"HDL-32E", "velodyne", 2368, false, &make_velodyne_decoder},
    {"OS-LEGACY", "ouster", 7502, true, &make_ouster_decoder},
    {"OS", "ouster", 7502, true, &make_ouster_decoder},
    {"Pandar40P", "hesai", 2368, false, &make_hesai_decoder},
    {"PandarXT32", "hesai", 2368, false, &make_hesai_decoder},
};

}  // namespace

std::span<const ModelEntry> known_models() noexcept { return kModels; }

const ModelEntry* find_model(std::string_view name) noexcept {
  for (const auto& m : kModels)
    if (m.name == name) return &m;
  return nullptr;
}

std::string implemented_model_names() {
  std::string s;
  for (const auto& m : kModels)
    if (m.make != nullptr) s += (s.empty() ? "" : ", ") + std::string(m.name);
  return s;
}

std::unique_ptr<ScanDecoder> make_decoder(const DecoderOptions& o) {
  const auto* m = find_model(o.model);
  if (m == nullptr)
    throw DecoderConfigError("unknown model '" + o.model + "' (supported: " + implemented_model_names() + ")");
  if (m->make == nullptr)
    throw DecoderConfigError("model " + o.model + " is not supported yet (supported: " + implemented_model_names() + ")");
  if (m->needs_metadata && o.metadata_text.empty())
    throw DecoderConfigError("model " + o.model + " needs the sensor metadata JSON (--metadata)");
  return m->make(o);
}

}  // namespace sensor_rig::lidar
