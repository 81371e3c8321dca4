#pragma once
// A bounded FIFO that keeps the newest items: pushing into a full queue drops the oldest and counts
// it. One per (client, subscription): a viewer that falls behind sees the latest samples, late ones
// are dropped and reported, and nothing upstream waits for it.
#include <cstddef>
#include <cstdint>
#include <deque>
#include <utility>

namespace sensor_rig::view {

template <class T>
class LatestQueue {
 public:
  explicit LatestQueue(std::size_t capacity) : capacity_(capacity == 0 ? 1 : capacity) {}

  // Returns true when an older item was dropped to make room.
  bool push(T item) {
    bool dropped = false;
    if (items_.size() >= capacity_) {
      items_.pop_front();
      ++dropped_;
      dropped = true;
    }
    items_.push_back(std::move(item));
    return dropped;
  }
  [[nodiscard]] bool empty() const noexcept { return items_.empty(); }
  [[nodiscard]] std::size_t size() const noexcept { return items_.size(); }
  [[nodiscard]] std::size_t capacity() const noexcept { return capacity_; }
  [[nodiscard]] const T& front() const { return items_.front(); }
  T pop() {
    T t = std::move(items_.front());
    items_.pop_front();
    return t;
  }
  [[nodiscard]] std::uint64_t dropped() const noexcept { return dropped_; }

 private:
  std::size_t capacity_;
  std::deque<T> items_;
  std::uint64_t dropped_ = 0;
};

}  // namespace sensor_rig::view
