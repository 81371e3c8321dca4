#pragma once
// A bounded single-producer single-consumer queue of datagram records between a LIDAR's receive
// thread and its recording's writer thread: one byte ring allocated once, each record stored as a
// fixed head (time, headers) followed by its payload. push() never blocks and never allocates: a
// record that does not fit is refused and counted. The consumer reads records in place and frees
// each after its callback returns, so the producer gets the room back record by record.
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <new>
#include <span>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/pcap_recorder.hpp"

namespace sensor_rig::lidar {

class RecordQueue {
 public:
  // Throws std::invalid_argument when capacity_bytes cannot hold one largest datagram.
  explicit RecordQueue(std::size_t capacity_bytes);

  // Producer: copies the record in; false when the queue is full (counted in dropped()).
  bool push(std::span<const std::byte> payload, Nanos rx_ns, const DatagramHeaders& h) noexcept;

  // Consumer: calls f(payload, rx_ns, headers) for every record queued now, oldest first; the
  // spans are valid during the call. Returns how many records were passed.
  template <class F>
  std::size_t drain(F&& f) noexcept(noexcept(f(std::span<const std::byte>{}, Nanos{}, DatagramHeaders{})));

  [[nodiscard]] std::uint64_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::size_t capacity() const noexcept { return capacity_; }

 private:
  // The fixed part of a record; 0 bytes marks the ring's unused end (the next record is at 0).
  struct Head {
    std::uint32_t bytes = 0;  // the whole record, head and payload, a multiple of 8
    std::uint32_t payload_size = 0;
    Nanos rx_ns = 0;
    UdpAddressing addressing;
    std::uint8_t captured_size = 0;
    std::array<std::byte, kMaxCapturedHeaders> captured{};
  };
  static constexpr std::size_t kAlign = 8;
  static_assert(alignof(Head) <= kAlign);

  [[nodiscard]] const Head& head_at(std::uint64_t pos) const noexcept {
    return *std::launder(reinterpret_cast<const Head*>(bytes_ + pos % capacity_));
  }

  std::size_t capacity_;                    // a multiple of kAlign
  std::unique_ptr<std::uint64_t[]> words_;  // the ring, 8-aligned
  std::byte* bytes_;                        // words_ as bytes
  // Monotonic byte counts: head_ written by the producer, tail_ by the consumer.
  alignas(64) std::atomic<std::uint64_t> head_{0};
  alignas(64) std::atomic<std::uint64_t> tail_{0};
  std::atomic<std::uint64_t> dropped_{0};
};

template <class F>
std::size_t RecordQueue::drain(F&& f) noexcept(noexcept(f(std::span<const std::byte>{}, Nanos{}, DatagramHeaders{}))) {
  std::uint64_t tail = tail_.load(std::memory_order_relaxed);
  const std::uint64_t head = head_.load(std::memory_order_acquire);  // the producer's writes before it
  std::size_t n = 0;
  while (tail != head) {
    std::uint32_t bytes = 0;
    std::memcpy(&bytes, bytes_ + tail % capacity_, sizeof bytes);
    if (bytes == 0) {  // the end marker: the rest of the ring was too short for the next record
      tail += capacity_ - tail % capacity_;
    } else {
      const Head& h = head_at(tail);
      const auto* payload = reinterpret_cast<const std::byte*>(&h) + sizeof(Head);
      const DatagramHeaders headers{h.addressing, std::span<const std::byte>(h.captured).first(h.captured_size)};
      f(std::span<const std::byte>(payload, h.payload_size), h.rx_ns, headers);
      tail += h.bytes;
      ++n;
    }
    tail_.store(tail, std::memory_order_release);  // our reads before it: the room is the producer's again
  }
  return n;
}

}  // namespace sensor_rig::lidar
