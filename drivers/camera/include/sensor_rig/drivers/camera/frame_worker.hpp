#pragma once
// The hand-off from a camera's capture thread to its image worker (colour, JPEG): a bounded queue
// of `depth` (1-2) frames in buffers allocated once. offer() copies the frame into a free buffer and
// never waits for the worker: when every buffer is taken, the oldest queued frame is overwritten
// and counted as dropped. The worker thread calls `process` for each frame, newest kept.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "sensor_rig/camera/frame.hpp"
#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::drivers {

struct WorkerJob {
  camera::FrameMeta meta;
  Nanos stamp_ns = 0;     // header.stamp of the raw image (vehicle time)
  Nanos queued_ns = 0;    // vehicle time offer() finished
  std::span<const std::uint8_t> data;
};

struct WorkerCounters {
  std::uint64_t offered = 0;
  std::uint64_t processed = 0;
  std::uint64_t dropped = 0;    // overwritten in the queue before the worker took them
  std::uint64_t oversize = 0;   // larger than a buffer: not queued
  double last_process_ms = 0.0;
  double max_process_ms = 0.0;
};

class FrameWorker {
 public:
  using Process = std::function<void(const WorkerJob&)>;
  // `name` names the thread (pthread name, 15 chars); `max_bytes`: the largest frame.
  FrameWorker(std::string name, std::size_t max_bytes, int depth, Process process);
  ~FrameWorker();
  FrameWorker(const FrameWorker&) = delete;
  FrameWorker& operator=(const FrameWorker&) = delete;

  void start();
  void stop();
  // Capture thread only (one producer). False when the frame is larger than a buffer.
  bool offer(const camera::FrameMeta& meta, Nanos stamp_ns, std::span<const std::uint8_t> data);
  [[nodiscard]] WorkerCounters counters() const;
  [[nodiscard]] int depth() const noexcept { return depth_; }

 private:
  struct Slot {
    std::unique_ptr<std::uint8_t[]> bytes;
    WorkerJob job;
  };
  void run();

  std::string name_;
  std::size_t max_bytes_;
  int depth_;
  Process process_;
  std::vector<Slot> slots_;  // depth + 1: one for the worker, `depth` queued
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::vector<std::size_t> free_;
  std::deque<std::size_t> queue_;
  WorkerCounters counters_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace sensor_rig::drivers
