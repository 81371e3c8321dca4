#include "sensor_rig/lidar/mock/scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sensor_rig::lidar::mock {
namespace {

constexpr double kEps = 1e-12;

// Slab test on one axis: narrows [t0, t1]; false when the ray misses the slab.
bool slab(double o, double d, double lo, double hi, double& t0, double& t1) noexcept {
  if (std::fabs(d) < kEps) return o >= lo && o <= hi;
  double a = (lo - o) / d;
  double b = (hi - o) / d;
  if (a > b) std::swap(a, b);
  t0 = std::max(t0, a);
  t1 = std::min(t1, b);
  return t0 <= t1;
}

double box_distance(const Surface& s, const Vec3& p) noexcept {
  const double qx = std::max({s.min.x - p.x, 0.0, p.x - s.max.x});
  const double qy = std::max({s.min.y - p.y, 0.0, p.y - s.max.y});
  const double qz = std::max({s.min.z - p.z, 0.0, p.z - s.max.z});
  const double outside = std::sqrt(qx * qx + qy * qy + qz * qz);
  if (outside > 0.0) return outside;
  return std::min({p.x - s.min.x, s.max.x - p.x, p.y - s.min.y, s.max.y - p.y, p.z - s.min.z, s.max.z - p.z});
}

}  // namespace

Scene Scene::standard(const SceneParams& p) {
  Scene s;
  const double g = -p.sensor_height_m;
  const double top = g + p.wall_height_m;
  const double hx = p.room_half_x_m, hy = p.room_half_y_m;
  s.add({{-hx, -hy, g}, {hx, hy, g}, 20, "ground"});
  s.add({{hx, -hy, g}, {hx, hy, top}, 60, "wall +x"});
  s.add({{-hx, -hy, g}, {-hx, hy, top}, 70, "wall -x"});
  s.add({{-hx, hy, g}, {hx, hy, top}, 80, "wall +y"});
  s.add({{-hx, -hy, g}, {hx, -hy, top}, 90, "wall -y"});
  s.add({{7.0, -4.0, g}, {11.5, -2.2, g + 1.5}, 140, "car"});
  s.add({{-6.0, 5.0, g}, {-5.4, 5.6, top}, 200, "pillar"});
  s.add({{2.0, 9.0, g}, {3.2, 10.2, g + 0.8}, 110, "crate"});
  return s;
}

std::optional<Hit> Scene::cast(const Vec3& o, const Vec3& d, double max_range) const noexcept {
  std::optional<Hit> best;
  double best_t = max_range;
  for (std::size_t i = 0; i < surfaces_.size(); ++i) {
    const Surface& s = surfaces_[i];
    double t0 = 1e-6, t1 = std::numeric_limits<double>::infinity();
    if (!slab(o.x, d.x, s.min.x, s.max.x, t0, t1) || !slab(o.y, d.y, s.min.y, s.max.y, t0, t1) ||
        !slab(o.z, d.z, s.min.z, s.max.z, t0, t1)) {
      continue;
    }
    if (t0 <= best_t) {
      best_t = t0;
      best = Hit{t0, s.reflectivity, i};
    }
  }
  return best;
}

double Scene::distance_to_surface(const Vec3& p, std::size_t* which) const noexcept {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < surfaces_.size(); ++i) {
    const double d = box_distance(surfaces_[i], p);
    if (d < best) {
      best = d;
      if (which) *which = i;
    }
  }
  return best;
}

}  // namespace sensor_rig::lidar::mock
