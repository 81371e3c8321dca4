#include "sensor_rig/timesync/monotonic_stamps.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace sensor_rig::timesync {

MonotonicStamps::MonotonicStamps(double slew_fraction, Nanos step_threshold_ns)
    : slew_(slew_fraction), threshold_(step_threshold_ns) {
  if (!(slew_fraction > 0.0 && slew_fraction < 1.0)) throw std::invalid_argument("MonotonicStamps: slew_fraction must be in (0, 1)");
  if (step_threshold_ns < 0) throw std::invalid_argument("MonotonicStamps: step_threshold_ns must be >= 0");
}

void MonotonicStamps::reset() noexcept {
  have_ = false;
  st_.correction_ns = 0;
}

Nanos MonotonicStamps::apply(Nanos raw) noexcept {
  if (!have_) {
    have_ = true;
    last_raw_ = last_out_ = raw;
    return raw;
  }
  const Nanos d = raw - last_raw_;
  last_raw_ = raw;
  Nanos& c = st_.correction_ns;
  if (d > 0 && c > 0) c -= std::min(c, static_cast<Nanos>(std::ceil(slew_ * static_cast<double>(d))));
  Nanos out = raw + c;
  if (out < last_out_) {
    // Backwards (a host step back, or a refit moving the mapping by a few µs): hold at the last
    // output and slew the difference out from here on.
    ++st_.held;
    if (last_out_ - out > threshold_) {
      ++st_.backward_steps;
      st_.last_backward_ns = last_out_ - out;
    }
    c += last_out_ - out;
    st_.max_correction_ns = std::max(st_.max_correction_ns, c);
    out = last_out_;
  }
  last_out_ = out;
  return out;
}

}  // namespace sensor_rig::timesync
