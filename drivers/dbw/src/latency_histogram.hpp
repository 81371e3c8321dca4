#pragma once
// Latency percentiles in fixed memory: 1 µs bins up to 20 ms, one overflow bin. Recording is O(1)
// and never allocates (the bridge records every command for as long as it runs).
#include <algorithm>
#include <array>
#include <cstdint>

namespace sensor_rig::drivers {

class LatencyHistogram {
 public:
  static constexpr std::size_t kBins = 20'000;  // µs

  void record(double us) noexcept {
    const double c = std::clamp(us, 0.0, static_cast<double>(kBins));
    ++bins_[static_cast<std::size_t>(c)];
    ++count_;
    max_us_ = std::max(max_us_, us);
  }
  [[nodiscard]] std::uint64_t count() const noexcept { return count_; }
  [[nodiscard]] double max_us() const noexcept { return max_us_; }
  // Nearest-rank percentile (q in 0..1), to the bin's upper edge; 0 when empty.
  [[nodiscard]] double percentile_us(double q) const noexcept {
    if (count_ == 0) return 0.0;
    const auto rank = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(q * static_cast<double>(count_) + 0.999999));
    std::uint64_t seen = 0;
    for (std::size_t i = 0; i < bins_.size(); ++i) {
      seen += bins_[i];
      if (seen >= rank) return i + 1 < bins_.size() ? static_cast<double>(i + 1) : max_us_;
    }
    return max_us_;
  }

 private:
  std::array<std::uint64_t, kBins + 1> bins_{};
  std::uint64_t count_ = 0;
  double max_us_ = 0.0;
};

}  // namespace sensor_rig::drivers
