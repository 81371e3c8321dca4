#pragma once
// A bounded FIFO that keeps the newest items: a push beyond the bounds drops the oldest and counts
// it. One per (client, subscription): a viewer that falls behind sees the latest samples, late ones
// are dropped and reported, and nothing upstream waits for it.
//
// Bounds: always up to `min_items`; beyond that only while the queued bytes stay within
// `max_bytes`, and never more than `max_items`. So a topic of 1 MB clouds keeps `min_items` of
// them, while /rig/stamps (~200 B, in bursts of one per sensor) keeps a burst or more instead of
// dropping what a client about to read it would have had.
#include <cstddef>
#include <cstdint>
#include <deque>
#include <utility>

namespace sensor_rig::view {

struct QueueLimits {
  std::size_t min_items = 4;
  std::size_t max_items = 256;
  std::size_t max_bytes = 1 << 20;
};

template <class T>
class LatestQueue {
 public:
  explicit LatestQueue(QueueLimits limits) : limits_(limits) {
    if (limits_.min_items == 0) limits_.min_items = 1;  // 0 would drop everything
    if (limits_.max_items < limits_.min_items) limits_.max_items = limits_.min_items;
  }

  // Returns how many older items were dropped to make room.
  std::size_t push(T item, std::size_t bytes) {
    items_.emplace_back(std::move(item), bytes);
    bytes_ += bytes;
    std::size_t dropped = 0;
    while (items_.size() > limits_.max_items || (items_.size() > limits_.min_items && bytes_ > limits_.max_bytes)) {
      bytes_ -= items_.front().second;
      items_.pop_front();
      ++dropped;
    }
    dropped_ += dropped;
    return dropped;
  }
  [[nodiscard]] bool empty() const noexcept { return items_.empty(); }
  [[nodiscard]] std::size_t size() const noexcept { return items_.size(); }
  [[nodiscard]] std::size_t bytes() const noexcept { return bytes_; }
  [[nodiscard]] const QueueLimits& limits() const noexcept { return limits_; }
  [[nodiscard]] const T& front() const { return items_.front().first; }
  T pop() {
    T t = std::move(items_.front().first);
    bytes_ -= items_.front().second;
    items_.pop_front();
    return t;
  }
  [[nodiscard]] std::uint64_t dropped() const noexcept { return dropped_; }

 private:
  QueueLimits limits_;
  std::deque<std::pair<T, std::size_t>> items_;
  std::size_t bytes_ = 0;
  std::uint64_t dropped_ = 0;
};

}  // namespace sensor_rig::view
