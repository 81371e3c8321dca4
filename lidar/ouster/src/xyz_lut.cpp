// Projection table (see xyz_lut.hpp). Built in double, stored in float.
#include "xyz_lut.hpp"

#include <cmath>
#include <numbers>

namespace sensor_rig::lidar::ouster {

XyzLut::XyzLut(const SensorMetadata& m)
    : cols_(static_cast<std::size_t>(m.columns_per_frame)), rows_(static_cast<std::size_t>(m.pixels_per_column)) {
  constexpr double kPi = std::numbers::pi;
  constexpr double kMmToM = 0.001;
  const auto& b = m.beam_to_lidar;
  const auto& t = m.lidar_to_sensor;
  const double bx = b[3];
  const double bz = b[11];
  const double d = bz != 0.0 ? std::hypot(bx, bz) : bx;
  entries_.resize(cols_ * rows_);
  for (std::size_t c = 0; c < cols_; ++c) {
    const double e = 2.0 * kPi - static_cast<double>(c) * 2.0 * kPi / static_cast<double>(cols_);
    const double ce = std::cos(e);
    const double se = std::sin(e);
    for (std::size_t r = 0; r < rows_; ++r) {
      const double a = -m.beam_azimuth_deg[r] * kPi / 180.0;
      const double p = m.beam_altitude_deg[r] * kPi / 180.0;
      const double dir[3] = {std::cos(e + a) * std::cos(p), std::sin(e + a) * std::cos(p), std::sin(p)};
      const double off[3] = {bx * ce - d * dir[0], bx * se - d * dir[1], bz - d * dir[2]};
      double rd[3];
      double ro[3];
      for (std::size_t i = 0; i < 3; ++i) {
        rd[i] = t[4 * i] * dir[0] + t[4 * i + 1] * dir[1] + t[4 * i + 2] * dir[2];
        ro[i] = t[4 * i] * off[0] + t[4 * i + 1] * off[1] + t[4 * i + 2] * off[2] + t[4 * i + 3];
      }
      entries_[c * rows_ + r] =
          LutEntry{static_cast<float>(rd[0] * kMmToM), static_cast<float>(rd[1] * kMmToM),
                   static_cast<float>(rd[2] * kMmToM), static_cast<float>(ro[0] * kMmToM),
                   static_cast<float>(ro[1] * kMmToM), static_cast<float>(ro[2] * kMmToM)};
    }
  }
}

}  // namespace sensor_rig::lidar::ouster
