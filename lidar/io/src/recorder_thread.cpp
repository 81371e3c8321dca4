// A recording's writer thread (see recorder_thread.hpp).
#include "sensor_rig/lidar/recorder_thread.hpp"

#include <chrono>
#include <stdexcept>
#include <utility>

namespace sensor_rig::lidar {

RecorderThread::RecorderThread(std::unique_ptr<RecordSink> sink, std::size_t queue_bytes, Nanos wake_period_ns)
    : sink_(std::move(sink)), queue_(queue_bytes), wake_period_ns_(wake_period_ns) {
  if (!sink_) throw std::invalid_argument("recorder thread: no sink");
  if (wake_period_ns_ <= 0) throw std::invalid_argument("recorder thread: wake period must be positive");
  sink_status_ = sink_->status();
  thread_ = std::thread([this] { run(); });
}

RecorderThread::~RecorderThread() { close(); }

void RecorderThread::close() noexcept {
  {
    std::lock_guard lock(mutex_);
    if (stop_) return;
    stop_ = true;
  }
  wake_.notify_one();
  thread_.join();
}

RecorderStatus RecorderThread::status() const {
  std::lock_guard lock(mutex_);
  return RecorderStatus{sink_status_, queue_.dropped()};
}

void RecorderThread::run() noexcept {
  std::unique_lock lock(mutex_);
  for (;;) {
    // Seen before the drain: everything pushed before close() is in the queue by then.
    const bool stopping = stop_;
    lock.unlock();
    const std::size_t written = queue_.drain(
        [this](std::span<const std::byte> payload, Nanos rx_ns, const DatagramHeaders& h) noexcept {
          sink_->write(payload, rx_ns, h);
        });
    if (stopping) sink_->close();
    RecordSinkStatus st;
    if (written > 0 || stopping) st = sink_->status();  // strings copied once per batch, not per record
    lock.lock();
    if (written > 0 || stopping) sink_status_ = std::move(st);
    if (stopping) return;
    wake_.wait_for(lock, std::chrono::nanoseconds(wake_period_ns_), [this] { return stop_; });
  }
}

}  // namespace sensor_rig::lidar
