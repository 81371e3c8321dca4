// Model registry and firing timing (VLP-16, VLP-32C, HDL-32E user manuals).
#include "sensor_rig/lidar/velodyne/model.hpp"

#include <array>
#include <cmath>

namespace sensor_rig::lidar::velodyne {
namespace {

constexpr std::array<ModelInfo, 3> kModels{{
    {Model::kVLP16, "VLP-16", ProductId::kVLP16, 16, 110.592, 2.304, 0.002, 100.0, 30000},
    {Model::kVLP32C, "VLP-32C", ProductId::kVLP32C, 32, 55.296, 2.304, 0.004, 200.0, 60000},
    {Model::kHDL32E, "HDL-32E", ProductId::kHDL32E, 32, 46.08, 1.152, 0.002, 100.0, 70000},
}};

}  // namespace

std::span<const ModelInfo> all_models() noexcept { return kModels; }

const ModelInfo& model_info(Model m) noexcept {
  for (const auto& info : kModels) {
    if (info.model == m) return info;
  }
  return kModels[0];
}

std::optional<Model> model_from_name(std::string_view name) noexcept {
  for (const auto& info : kModels) {
    if (info.name == name) return info.model;
  }
  return std::nullopt;
}

int channel_laser(Model m, int channel) noexcept {
  return m == Model::kVLP16 ? channel % 16 : channel;
}

std::uint32_t channel_offset_ns(Model m, int channel) noexcept {
  double us = 0.0;
  switch (m) {
    case Model::kVLP16: {
      const int sequence = channel / 16;  // two firing sequences of 16 lasers per block
      us = sequence * 55.296 + (channel % 16) * 2.304;
      break;
    }
    case Model::kVLP32C: {
      const int pair = channel / 2;  // the lasers fire in pairs
      us = pair * 2.304;
      break;
    }
    case Model::kHDL32E:
      us = channel * 1.152;
      break;
  }
  return static_cast<std::uint32_t>(std::lround(us * 1000.0));
}

}  // namespace sensor_rig::lidar::velodyne
