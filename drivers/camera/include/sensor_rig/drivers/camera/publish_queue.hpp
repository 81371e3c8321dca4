#pragma once
// The capture thread's hand-off to a publishing thread (issue 27 item 13): a DDS write to a slow
// reliable subscriber blocks (up to 50 ms a frame measured), and on the capture thread that wait
// starved the device's buffers and the trigger matching behind it. The capture thread pushes and
// never waits; the queue holds at most `depth` jobs, and a push into a full queue drops the oldest
// queued job, counted (a frame made and not published: the camera's counted_lost). drain() drops
// what is queued (counted) and waits for the job in flight: before the source is closed, whose
// buffers the jobs hold.
#include <pthread.h>

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

namespace sensor_rig::drivers {

template <typename Job>
class PublishQueue {
 public:
  using Process = std::function<void(Job&)>;
  PublishQueue(std::string thread_name, std::size_t depth, Process process)
      : name_(std::move(thread_name)), depth_(depth < 1 ? 1 : depth), process_(std::move(process)) {}
  ~PublishQueue() { stop(); }
  PublishQueue(const PublishQueue&) = delete;
  PublishQueue& operator=(const PublishQueue&) = delete;

  void start() {
    std::lock_guard lock(mutex_);
    if (thread_.joinable()) return;
    stop_ = false;
    thread_ = std::thread([this] { run(); });
    (void)pthread_setname_np(thread_.native_handle(), name_.substr(0, 15).c_str());
  }
  [[nodiscard]] std::thread& thread() noexcept { return thread_; }

  // Never waits for the publishing thread. Returns false when it dropped the oldest queued job.
  bool push(Job&& job) {
    Job dropped;
    bool full = false;
    {
      std::lock_guard lock(mutex_);
      if (queue_.size() >= depth_) {
        dropped = std::move(queue_.front());
        queue_.pop_front();
        ++dropped_;
        full = true;
      }
      queue_.push_back(std::move(job));
    }
    cv_.notify_all();
    return !full;  // `dropped` (its frame's buffer) is released here, outside the lock
  }

  // Drops the queued jobs (counted) and waits until no job is being processed.
  void drain() {
    std::deque<Job> gone;
    std::unique_lock lock(mutex_);
    dropped_ += queue_.size();
    gone.swap(queue_);
    idle_cv_.wait(lock, [this] { return !busy_; });
  }

  // Processes what is queued, then ends the thread.
  void stop() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

  [[nodiscard]] std::uint64_t dropped() const {
    std::lock_guard lock(mutex_);
    return dropped_;
  }

 private:
  void run() {
    std::unique_lock lock(mutex_);
    for (;;) {
      cv_.wait(lock, [this] { return stop_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopped and nothing left
      Job job = std::move(queue_.front());
      queue_.pop_front();
      busy_ = true;
      lock.unlock();
      process_(job);
      job = Job{};  // its buffer goes back before drain() is told the thread is idle
      lock.lock();
      busy_ = false;
      idle_cv_.notify_all();
    }
  }

  const std::string name_;
  const std::size_t depth_;
  const Process process_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::condition_variable idle_cv_;
  std::deque<Job> queue_;
  std::uint64_t dropped_ = 0;
  bool busy_ = false;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace sensor_rig::drivers
