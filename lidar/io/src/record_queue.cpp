// Bounded SPSC record queue (see record_queue.hpp).
#include "sensor_rig/lidar/record_queue.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>

namespace sensor_rig::lidar {

RecordQueue::RecordQueue(std::size_t capacity_bytes)
    : capacity_(capacity_bytes / kAlign * kAlign),
      words_(std::make_unique<std::uint64_t[]>(capacity_ / kAlign)),
      bytes_(reinterpret_cast<std::byte*>(words_.get())) {
  if (capacity_ < 2 * (sizeof(Head) + kMaxRecordedPayload))
    throw std::invalid_argument("record queue: " + std::to_string(capacity_bytes) +
                                " bytes cannot hold two of the largest datagrams");
}

bool RecordQueue::push(std::span<const std::byte> payload, Nanos rx_ns, const DatagramHeaders& h) noexcept {
  const std::size_t need = (sizeof(Head) + payload.size() + kAlign - 1) / kAlign * kAlign;
  const std::uint64_t head = head_.load(std::memory_order_relaxed);
  const std::uint64_t tail = tail_.load(std::memory_order_acquire);  // the consumer is done with that room
  const std::size_t to_end = capacity_ - head % capacity_;
  const std::size_t skip = need > to_end ? to_end : 0;  // a record never wraps: it starts again at 0
  if (payload.size() > kMaxRecordedPayload || h.captured.size() > kMaxCapturedHeaders ||
      head + skip + need - tail > capacity_) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  if (skip != 0) {  // the end marker: a record size of 0 (8 bytes at least are left here)
    const std::uint32_t end = 0;
    std::memcpy(bytes_ + head % capacity_, &end, sizeof end);
  }
  std::byte* at = bytes_ + (head + skip) % capacity_;
  auto* rec = new (at) Head{};
  rec->bytes = static_cast<std::uint32_t>(need);
  rec->payload_size = static_cast<std::uint32_t>(payload.size());
  rec->rx_ns = rx_ns;
  rec->addressing = h.addressing;
  rec->captured_size = static_cast<std::uint8_t>(h.captured.size());
  std::copy(h.captured.begin(), h.captured.end(), rec->captured.begin());
  std::memcpy(at + sizeof(Head), payload.data(), payload.size());
  head_.store(head + skip + need, std::memory_order_release);  // the record's bytes before it
  return true;
}

}  // namespace sensor_rig::lidar
