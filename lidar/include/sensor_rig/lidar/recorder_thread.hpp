#pragma once
// A LIDAR recording off the receive thread: the receive thread pushes each datagram into a bounded
// queue (record_queue.hpp: a copy, no syscall, no lock, never blocks); a writer thread wakes every
// wake_period_ns (or at close) and writes what is queued through its sink (the rotating pcap
// recorder). A slow or stalled disk fills the queue and the records that do not fit are dropped and
// counted (queue_dropped), never waited for: capture goes on. close() writes everything queued
// before it, then closes the sink (no lost tail).
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <thread>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/pcap_recorder.hpp"
#include "sensor_rig/lidar/record_queue.hpp"

namespace sensor_rig::lidar {

struct RecorderStatus {
  RecordSinkStatus sink;            // as of the writer's last batch
  std::uint64_t queue_dropped = 0;  // refused by the full queue: the writer fell behind
  // Every datagram not recorded: the sink's drops (errors, back-off) and the queue's.
  [[nodiscard]] std::uint64_t dropped() const noexcept { return sink.stats.dropped + queue_dropped; }
};

class RecorderThread {
 public:
  // Starts the writer thread; throws std::invalid_argument for a null sink or a queue too small.
  RecorderThread(std::unique_ptr<RecordSink> sink, std::size_t queue_bytes, Nanos wake_period_ns = 10'000'000);
  ~RecorderThread();  // close()
  RecorderThread(const RecorderThread&) = delete;
  RecorderThread& operator=(const RecorderThread&) = delete;

  // Receive thread: queues one datagram; false when the queue is full (counted).
  bool push(std::span<const std::byte> payload, Nanos rx_ns, const DatagramHeaders& h) noexcept {
    return queue_.push(payload, rx_ns, h);
  }
  // Writes what is queued, closes the sink, ends the thread. Call after the last push; idempotent.
  void close() noexcept;
  // Any thread.
  [[nodiscard]] RecorderStatus status() const;

 private:
  void run() noexcept;

  std::unique_ptr<RecordSink> sink_;  // the writer thread's only
  RecordQueue queue_;
  Nanos wake_period_ns_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;               // guarded by mutex_
  RecordSinkStatus sink_status_;    // guarded by mutex_
  std::thread thread_;
};

}  // namespace sensor_rig::lidar
