#include "sensor_rig/lidar/mock/fault_injector.hpp"

#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

namespace sensor_rig::lidar::mock {
namespace {

void check_rate(double v, const char* name) {
  if (!(v >= 0.0 && v <= 1.0)) {
    throw std::invalid_argument(std::string(name) + " must be in [0, 1], got " + std::to_string(v));
  }
}

}  // namespace

void FaultConfig::validate() const {
  check_rate(drop_rate, "--drop-rate");
  check_rate(corrupt_rate, "--corrupt-rate");
  check_rate(truncate_rate, "--truncate-rate");
  check_rate(duplicate_rate, "--duplicate-rate");
  check_rate(reorder_rate, "--reorder-rate");
  if (stall_ns < 0) throw std::invalid_argument("--stall-ms must be >= 0");
  if (stall_every_ns < 0) throw std::invalid_argument("--stall-every must be >= 0");
  if ((stall_ns > 0) != (stall_every_ns > 0)) {
    throw std::invalid_argument("--stall-ms and --stall-every go together");
  }
}

bool FaultConfig::any() const noexcept {
  return drop_rate > 0 || corrupt_rate > 0 || truncate_rate > 0 || duplicate_rate > 0 || reorder_rate > 0 ||
         (stall_ns > 0 && stall_every_ns > 0);
}

FaultInjector::FaultInjector(const FaultConfig& config, std::size_t max_packet_bytes)
    : cfg_(config), rng_(config.seed), next_stall_ns_(config.stall_every_ns) {
  cfg_.validate();
  cur_.reserve(max_packet_bytes);
  held_.reserve(max_packet_bytes);
  released_.reserve(max_packet_bytes);
}

bool FaultInjector::chance(double p) noexcept { return p > 0.0 && uniform_(rng_) < p; }

std::span<const FaultedPacket> FaultInjector::push(Nanos offset_ns, std::span<const std::byte> bytes, bool position,
                                                   std::int64_t tag) {
  // A stall delays this packet and everything after it.
  if (cfg_.stall_ns > 0 && cfg_.stall_every_ns > 0) {
    while (offset_ns >= next_stall_ns_) {
      delay_ns_ += cfg_.stall_ns;
      stats_.stalled_ns += cfg_.stall_ns;
      ++stats_.stalls;
      next_stall_ns_ += cfg_.stall_every_ns;
    }
  }
  const Nanos when = offset_ns + delay_ns_;
  std::size_t n = 0;

  if (chance(cfg_.drop_rate)) {
    ++stats_.dropped;
  } else {
    cur_.assign(bytes.begin(), bytes.end());
    if (!cur_.empty() && chance(cfg_.corrupt_rate)) {
      ++stats_.corrupted;
      const int flips = 1 + static_cast<int>(rng_() % 4);
      for (int i = 0; i < flips; ++i) {
        const std::size_t at = rng_() % cur_.size();
        cur_[at] ^= std::byte{static_cast<std::uint8_t>(1 + rng_() % 255)};
      }
    }
    if (cur_.size() > 1 && chance(cfg_.truncate_rate)) {
      ++stats_.truncated;
      cur_.resize(1 + rng_() % (cur_.size() - 1));
    }
    const bool dup = chance(cfg_.duplicate_rate);
    if (!have_held_ && chance(cfg_.reorder_rate)) {
      // Hold it: it goes out after the next packet (duplicates travel with it).
      ++stats_.reordered;
      std::swap(cur_, held_);
      have_held_ = true;
      held_position_ = position;
      held_tag_ = tag;
      last_when_ = when;
      if (dup) {
        // The duplicate leaves now; the original follows the next packet.
        ++stats_.duplicated;
        released_.assign(held_.begin(), held_.end());
        out_[n++] = FaultedPacket{when, released_, position, tag};
      }
      return {out_, n};
    }
    out_[n++] = FaultedPacket{when, cur_, position, tag};
    if (dup) {
      ++stats_.duplicated;
      out_[n++] = FaultedPacket{when, cur_, position, tag};
    }
  }
  last_when_ = when;
  if (have_held_ && n > 0) {
    std::swap(held_, released_);
    have_held_ = false;
    out_[n++] = FaultedPacket{when, released_, held_position_, held_tag_};
  }
  return {out_, n};
}

std::span<const FaultedPacket> FaultInjector::flush() {
  if (!have_held_) return {};
  std::swap(held_, released_);
  have_held_ = false;
  out_[0] = FaultedPacket{last_when_, released_, held_position_, held_tag_};
  return {out_, 1};
}

}  // namespace sensor_rig::lidar::mock
