#pragma once
// What the bridge's control threads hand to its publisher thread: safety events (with the status
// they left behind) and per-command stamps. A fixed ring under its own small lock: the control
// path neither allocates nor waits on DDS writes; when full, new items are counted and dropped.
#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/bridge/bridge_core.hpp"
#include "sensor_rig/dbw/can/transport.hpp"
#include "sensor_rig/dbw/safety/safety_core.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"

namespace sensor_rig::drivers {

// The bridge's state as rt/vehicle/dbw/status reports it (plain values, copied under the lock).
struct StatusSnapshot {
  dbw::safety::State state = dbw::safety::State::kDisengaged;
  dbw::safety::Reason reason = dbw::safety::Reason::kNone;
  dbw::safety::SafetyCounters counters{};
  dbw::safety::EcuStatus ecu{};
  const char* bus_state = "active";
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_received = 0;
};

struct OutboxItem {
  // kPeriodic: the 10 Hz status, queued like the events so that samples keep their order.
  enum class Kind : std::uint8_t { kEvent, kPeriodic, kStamps, kState } kind = Kind::kEvent;
  dbw::safety::Event event{};  // event.t in vehicle time (kPeriodic: the snapshot's time)
  StatusSnapshot status{};
  Nanos stamp = 0;        // kStamps: the command's header stamp
  std::uint64_t seq = 0;  // kStamps: the command's seq
  dds::SampleStamps stamps{};
  dbw::VehicleFeedback feedback{};  // kState
};

class Outbox {
 public:
  static constexpr std::size_t kCapacity = 256;

  // `wake`: notify the publisher now (events); stamps wait for its next poll. False: full, dropped.
  bool push(const OutboxItem& item, bool wake) noexcept {
    {
      std::lock_guard<std::mutex> lock(mu_);
      if (size_ == items_.size()) {
        ++dropped_;
        return false;
      }
      items_[(head_ + size_) % items_.size()] = item;
      ++size_;
    }
    if (wake) cv_.notify_one();
    return true;
  }
  // Waits up to `ms` for items, then hands each to `f` (outside the lock) and returns how many.
  template <class F>
  std::size_t drain(int ms, F&& f) {
    std::array<OutboxItem, 16> batch;
    std::size_t n = 0;
    {
      std::unique_lock<std::mutex> lock(mu_);
      cv_.wait_for(lock, std::chrono::milliseconds(ms), [this] { return size_ > 0; });
      while (n < batch.size() && size_ > 0) {
        batch[n++] = items_[head_];
        head_ = (head_ + 1) % items_.size();
        --size_;
      }
    }
    for (std::size_t i = 0; i < n; ++i) f(batch[i]);
    return n;
  }
  [[nodiscard]] std::uint64_t dropped() const {
    std::lock_guard<std::mutex> lock(mu_);
    return dropped_;
  }

 private:
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::array<OutboxItem, kCapacity> items_{};
  std::size_t head_ = 0;
  std::size_t size_ = 0;
  std::uint64_t dropped_ = 0;
};

// Received CAN frames for the raw channel (/vehicle/can/frames), filled by the CAN thread only while
// a reader is matched and written by the publisher thread: the control path never waits on a DDS
// write. Its own ring, so a busy bus never crowds the events and stamps out of the outbox. Full:
// the frame is counted and dropped.
class RawFrameRing {
 public:
  static constexpr std::size_t kCapacity = 1024;

  bool push(const dbw::can::RxFrame& f) noexcept {
    std::lock_guard<std::mutex> lock(mu_);
    if (size_ == items_.size()) {
      ++dropped_;
      return false;
    }
    items_[(head_ + size_) % items_.size()] = f;
    ++size_;
    return true;
  }
  // Hands every queued frame to `f` (64 at a time, outside the lock); returns how many.
  template <class F>
  std::size_t drain(F&& f) {
    std::size_t total = 0;
    std::array<dbw::can::RxFrame, 64> batch;
    for (;;) {
      std::size_t n = 0;
      {
        std::lock_guard<std::mutex> lock(mu_);
        while (n < batch.size() && size_ > 0) {
          batch[n++] = items_[head_];
          head_ = (head_ + 1) % items_.size();
          --size_;
        }
      }
      for (std::size_t i = 0; i < n; ++i) f(batch[i]);
      total += n;
      if (n < batch.size()) return total;
    }
  }
  [[nodiscard]] std::uint64_t dropped() const {
    std::lock_guard<std::mutex> lock(mu_);
    return dropped_;
  }

 private:
  mutable std::mutex mu_;
  std::array<dbw::can::RxFrame, kCapacity> items_{};
  std::size_t head_ = 0;
  std::size_t size_ = 0;
  std::uint64_t dropped_ = 0;
};

// Per-command stamps waiting for the ECU's answer (the `ecu` stage of rig monitor): the first ECU
// status frame received after the command's CAN frames were written. The reference protocol (and
// the mock ECU) echo no request or counter back, so that frame is the first that can reflect the
// command — the stage includes the wait for the ECU's status period. Measured only: stamps whose
// status never comes (ECU silent, timeout) go out with ecu_status_ns = 0. Fixed capacity, no
// allocation; the caller serializes (the bridge's lock).
class AwaitingEcu {
 public:
  static constexpr std::size_t kCapacity = 32;

  // A command's stamps (stamps.written_ns set). `out` gets the oldest waiting one when full.
  template <class Out>
  void on_written(const OutboxItem& item, Out&& out) {
    if (size_ == items_.size()) out(pop());
    items_[(head_ + size_) % items_.size()] = item;
    ++size_;
  }
  // A frame from the ECU: handed to `core` (at monotonic `mono`), whose classification is returned.
  // If the core took it as the ECU's status (it passed its E2E check and carries ready/override/
  // fault: BridgeCounters::status_frames went up — also a message that carries feedback too), every
  // waiting command written before the frame's receive stamp (vehicle time) is completed with that
  // stamp and handed to `out`, in order.
  template <class Out>
  dbw::RxKind on_frame(dbw::BridgeCore& core, const dbw::can::RxFrame& rx, Nanos mono, Out&& out) {
    const std::uint64_t before = core.counters().status_frames;
    const dbw::RxKind kind = core.on_frame(rx, mono);
    if (core.counters().status_frames == before) return kind;
    while (size_ > 0 && items_[head_].stamps.written_ns < rx.stamp) {
      OutboxItem it = pop();
      it.stamps.ecu_status_ns = rx.stamp;
      out(it);
    }
    return kind;
  }
  // Waiting stamps written at or before `now_ns - timeout_ns` go to `out` without an ECU stamp
  // (`timeout_ns` < 0: all of them, e.g. when stopping).
  template <class Out>
  void expire(Nanos now_ns, Nanos timeout_ns, Out&& out) {
    while (size_ > 0 && (timeout_ns < 0 || items_[head_].stamps.written_ns <= now_ns - timeout_ns)) out(pop());
  }
  [[nodiscard]] std::size_t size() const noexcept { return size_; }

 private:
  OutboxItem pop() noexcept {
    OutboxItem it = items_[head_];
    head_ = (head_ + 1) % items_.size();
    --size_;
    return it;
  }
  std::array<OutboxItem, kCapacity> items_{};
  std::size_t head_ = 0;
  std::size_t size_ = 0;
};

}  // namespace sensor_rig::drivers
