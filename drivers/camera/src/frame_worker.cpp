#include "sensor_rig/drivers/camera/frame_worker.hpp"

#include <pthread.h>

#include <algorithm>
#include <cstring>

namespace sensor_rig::drivers {

FrameWorker::FrameWorker(std::string name, std::size_t max_bytes, int depth, Process process)
    : name_(std::move(name)), max_bytes_(max_bytes), depth_(std::clamp(depth, 1, 2)), process_(std::move(process)) {
  slots_.resize(static_cast<std::size_t>(depth_) + 1);
  for (std::size_t i = 0; i < slots_.size(); ++i) {
    slots_[i].bytes = std::make_unique<std::uint8_t[]>(max_bytes_);
    std::memset(slots_[i].bytes.get(), 0, max_bytes_);  // touched once, not at the first frame
    free_.push_back(i);
  }
}

FrameWorker::~FrameWorker() { stop(); }

void FrameWorker::start() {
  if (thread_.joinable()) return;
  {
    std::lock_guard lock(mutex_);
    stop_ = false;
  }
  thread_ = std::thread([this] { run(); });
  const std::string thread_name = name_.substr(0, 15);
  (void)pthread_setname_np(thread_.native_handle(), thread_name.c_str());
}

void FrameWorker::stop() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

bool FrameWorker::offer(const camera::FrameMeta& meta, Nanos stamp_ns, std::span<const std::uint8_t> data) {
  std::size_t slot = 0;
  {
    std::lock_guard lock(mutex_);
    ++counters_.offered;
    if (data.size() > max_bytes_) {
      ++counters_.oversize;
      return false;
    }
    if (!free_.empty()) {
      slot = free_.back();
      free_.pop_back();
    } else {  // depth frames queued, one being processed: the oldest queued one makes room
      slot = queue_.front();
      queue_.pop_front();
      ++counters_.dropped;
    }
  }
  // The slot is the producer's alone until it is queued: copy without the lock.
  auto& s = slots_[slot];
  std::memcpy(s.bytes.get(), data.data(), data.size());
  s.job.meta = meta;
  s.job.stamp_ns = stamp_ns;
  s.job.data = {s.bytes.get(), data.size()};
  s.job.queued_ns = vehicle_now_ns();
  {
    std::lock_guard lock(mutex_);
    queue_.push_back(slot);
  }
  cv_.notify_one();
  return true;
}

WorkerCounters FrameWorker::counters() const {
  std::lock_guard lock(mutex_);
  return counters_;
}

void FrameWorker::run() {
  for (;;) {
    std::size_t slot = 0;
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
      if (stop_) return;
      slot = queue_.front();
      queue_.pop_front();
    }
    const Nanos t0 = monotonic_now_ns();
    process_(slots_[slot].job);
    const double ms = static_cast<double>(monotonic_now_ns() - t0) * 1e-6;
    std::lock_guard lock(mutex_);
    free_.push_back(slot);
    ++counters_.processed;
    counters_.last_process_ms = ms;
    counters_.max_process_ms = std::max(counters_.max_process_ms, ms);
  }
}

}  // namespace sensor_rig::drivers
