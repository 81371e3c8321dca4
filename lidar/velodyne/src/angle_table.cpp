#include "angle_table.hpp"

#include <cmath>
#include <numbers>

namespace sensor_rig::lidar::velodyne {

AngleTable::AngleTable() noexcept : sin{}, cos{} {
  for (std::size_t i = 0; i < sin.size(); ++i) {
    const double a = static_cast<double>(i) * (std::numbers::pi / 18000.0);
    sin[i] = static_cast<float>(std::sin(a));
    cos[i] = static_cast<float>(std::cos(a));
  }
}

const AngleTable kAngles;

}  // namespace sensor_rig::lidar::velodyne
