#pragma once
// The hand-over between `rig record`'s DDS thread and its writer thread: bounded by bytes (and per
// topic by count), so a writer that falls behind costs counted drops, not unbounded memory or
// iceoryx chunks held until the publisher's pool runs dry.
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>

#include "sensor_rig/dds/raw_topic.hpp"

namespace sensor_rig::rig {

struct RecordTopic;  // recorder.cpp

struct RecordItem {
  RecordTopic* topic = nullptr;
  dds::RawSample sample;
};

class RecordQueue {
 public:
  explicit RecordQueue(std::size_t max_bytes) : max_bytes_(max_bytes) {}
  // False (nothing queued) when the bytes would exceed the bound.
  bool push(RecordItem&& item) {
    const std::size_t n = item.sample.size();
    {
      std::lock_guard lock(mu_);
      if (bytes_ + n > max_bytes_ && !items_.empty()) return false;
      bytes_ += n;
      items_.push_back(std::move(item));
    }
    cv_.notify_one();
    return true;
  }
  // Waits up to `timeout` for an item; false when none (or closed and empty).
  bool pop(RecordItem& out, std::chrono::milliseconds timeout) {
    std::unique_lock lock(mu_);
    cv_.wait_for(lock, timeout, [&] { return !items_.empty() || closed_; });
    if (items_.empty()) return false;
    out = std::move(items_.front());
    items_.pop_front();
    bytes_ -= out.sample.size();
    return true;
  }
  void close() {
    {
      std::lock_guard lock(mu_);
      closed_ = true;
    }
    cv_.notify_all();
  }
  [[nodiscard]] bool closed_and_empty() {
    std::lock_guard lock(mu_);
    return closed_ && items_.empty();
  }
  [[nodiscard]] std::size_t bytes() {
    std::lock_guard lock(mu_);
    return bytes_;
  }

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<RecordItem> items_;
  std::size_t bytes_ = 0;
  std::size_t max_bytes_;
  bool closed_ = false;
};

}  // namespace sensor_rig::rig
