#include "sensor_rig/drivers/lidar/sweep_samples.hpp"

#include <cmath>
#include <numbers>

namespace sensor_rig::drivers {

void sweep_samples(const lidar::Scan& scan, std::vector<timesync::SweepSample>& out, std::size_t max_samples,
                   double min_range_m) {
  out.clear();
  const std::size_t n = scan.points.size();
  if (n == 0 || max_samples == 0) return;
  const std::size_t stride = (n + max_samples - 1) / max_samples;
  const double min_r2 = min_range_m * min_range_m;
  for (std::size_t i = 0; i < n; i += stride) {
    const auto& p = scan.points[i];
    const double x = static_cast<double>(p.x), y = static_cast<double>(p.y);
    if (!(x * x + y * y >= min_r2)) continue;  // also NaN
    double az = std::atan2(y, x) * (180.0 / std::numbers::pi);
    if (az < 0) az += 360.0;
    out.push_back({az, scan.stamp + static_cast<Nanos>(p.t)});
  }
}

}  // namespace sensor_rig::drivers
