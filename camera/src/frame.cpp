#include "sensor_rig/camera/frame.hpp"

#include <cstring>
#include <stdexcept>

namespace sensor_rig::camera {

const char* to_string(TimeDomain d) noexcept {
  switch (d) {
    case TimeDomain::kDeviceTicks: return "device_ticks";
    case TimeDomain::kMonotonic: return "monotonic";
    case TimeDomain::kVehicle: return "vehicle";
  }
  return "?";
}

BufferPool::BufferPool(std::size_t count, std::size_t bytes) : bytes_(bytes) {
  if (count == 0 || bytes == 0) throw std::invalid_argument("BufferPool: count and bytes must be > 0");
  buffers_.reserve(count);
  free_.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    buffers_.push_back(std::make_unique<std::uint8_t[]>(bytes));  // value-initialised: pages touched now
    free_.push_back(count - 1 - i);
  }
}

std::optional<std::size_t> BufferPool::acquire() {
  std::lock_guard lock(mutex_);
  if (free_.empty()) return std::nullopt;
  const auto i = free_.back();
  free_.pop_back();
  return i;
}

void BufferPool::release(std::size_t index) {
  std::lock_guard lock(mutex_);
  if (index < buffers_.size()) free_.push_back(index);
}

std::span<std::uint8_t> BufferPool::buffer(std::size_t index) const noexcept {
  if (index >= buffers_.size()) return {};
  return {buffers_[index].get(), bytes_};
}

std::size_t BufferPool::available() const {
  std::lock_guard lock(mutex_);
  return free_.size();
}

}  // namespace sensor_rig::camera
