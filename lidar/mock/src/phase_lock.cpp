#include "sensor_rig/lidar/mock/phase_lock.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "sensor_rig/common/floor_div.hpp"

namespace sensor_rig::lidar::mock {
namespace {

constexpr Nanos kSecondNs = 1'000'000'000;

double wrap_deg(double a) noexcept {
  const double w = std::fmod(a, 360.0);
  return w < 0 ? w + 360.0 : w;
}

}  // namespace

std::string phase_lock_error(double rotation_period_ns) {
  if (!(rotation_period_ns > 0) || !std::isfinite(rotation_period_ns)) return "phase lock: no rotation period";
  const double turns_per_second = 1e9 / rotation_period_ns;
  if (std::abs(turns_per_second - std::round(turns_per_second)) > 1e-6) {
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  "phase lock needs a whole number of turns per second (e.g. 300, 600, 1200 rpm), not %.4g Hz",
                  turns_per_second);
    return buf;
  }
  return {};
}

Nanos phase_locked_start_ns(const SyntheticSensor& sensor, Nanos earliest, double phase_deg) {
  if (!(phase_deg >= 0.0 && phase_deg < 360.0)) throw std::invalid_argument("phase lock: the angle must be in [0, 360)");
  const double period = sensor.rotation_period_ns();
  if (const std::string e = phase_lock_error(period); !e.empty()) throw std::invalid_argument(e);
  // The rotor reads phase_deg `lag` after the timeline starts (and every period after that); a
  // whole second S must be one of those moments: start = S + k·period - lag for whole k, because
  // a period divides the second.
  const double lag = wrap_deg(phase_deg - sensor.start_rotor_deg()) / 360.0 * period;
  const Nanos second = floor_div(earliest, kSecondNs) * kSecondNs;
  const double turns = std::ceil((static_cast<double>(earliest - second) + lag) / period - 1e-9);
  return second + std::llround(turns * period - lag);
}

double rotor_deg_at(const SyntheticSensor& sensor, Nanos start_ns, Nanos t) {
  return wrap_deg(sensor.start_rotor_deg() + static_cast<double>(t - start_ns) / sensor.rotation_period_ns() * 360.0);
}

}  // namespace sensor_rig::lidar::mock
