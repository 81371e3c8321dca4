#pragma once
// A simple static scene for synthetic LIDARs: axis-aligned rectangles and boxes (ground plane,
// walls, obstacles) in the sensor's REP 103 frame (x forward, y left, z up; metres; the sensor's
// optical centre at the origin). Pure geometry: ray casting and point-to-surface distance.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace sensor_rig::lidar::mock {

struct Vec3 {
  double x = 0, y = 0, z = 0;
};

// An axis-aligned box; a zero extent on one axis makes it a rectangle (ground, wall).
struct Surface {
  Vec3 min;
  Vec3 max;
  std::uint8_t reflectivity = 0;  // written as the Velodyne intensity byte
  std::string name;
};

struct Hit {
  double range = 0;                  // along the (unit) ray direction
  std::uint8_t reflectivity = 0;
  std::size_t surface = 0;           // index into Scene::surfaces
};

struct SceneParams {
  double sensor_height_m = 1.8;  // ground plane at z = -sensor_height
  double room_half_x_m = 30.0;   // walls at x = ±room_half_x ...
  double room_half_y_m = 22.0;   // ... and y = ±room_half_y
  double wall_height_m = 4.0;    // above the ground; rays above the walls see nothing
};

class Scene {
 public:
  // Ground, four walls and a few obstacles (a car-sized box, a pillar, a low crate).
  static Scene standard(const SceneParams& p = {});
  Scene() = default;

  void add(Surface s) { surfaces_.push_back(std::move(s)); }
  [[nodiscard]] const std::vector<Surface>& surfaces() const noexcept { return surfaces_; }

  // Nearest hit of the ray origin + t·dir with t in (0, max_range]; dir must be unit length.
  [[nodiscard]] std::optional<Hit> cast(const Vec3& origin, const Vec3& dir, double max_range) const noexcept;
  // Distance from p to the nearest surface (0 on a surface); `which` receives its index.
  [[nodiscard]] double distance_to_surface(const Vec3& p, std::size_t* which = nullptr) const noexcept;

 private:
  std::vector<Surface> surfaces_;
};

}  // namespace sensor_rig::lidar::mock
