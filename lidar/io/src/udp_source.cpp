#include "sensor_rig/lidar/udp_source.hpp"

#include <arpa/inet.h>
#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "sensor_rig/common/socket_options.hpp"

namespace sensor_rig::lidar {


SlotArena::SlotArena(std::size_t count, std::size_t slot_bytes)
    : storage_(count * slot_bytes), slots_(count) {
  if (count == 0 || slot_bytes == 0) throw std::invalid_argument("SlotArena needs count and slot_bytes > 0");
  for (std::size_t i = 0; i < count; ++i) {
    slots_[i].buffer = std::span<std::byte>(storage_).subspan(i * slot_bytes, slot_bytes);
  }
}

const char* to_string(RecvStatus s) noexcept {
  switch (s) {
    case RecvStatus::kOk: return "ok";
    case RecvStatus::kTimeout: return "timeout";
    case RecvStatus::kInterrupted: return "interrupted";
    case RecvStatus::kError: return "error";
  }
  return "unknown";
}

UdpSource::UdpSource(const UdpSourceConfig& config) : max_batch_(config.max_batch) {
  if (config.max_batch == 0 || config.max_batch > 1024) {
    throw std::invalid_argument("udp source: max_batch must be in 1..1024");
  }
  fd_ = UdpSocketBuilder{}
            .reuse_address(config.reuse_address)
            .receive_buffer(config.receive_buffer_bytes)
            .kernel_timestamps()
            .drop_counter()
            .destination_address()
            .nonblocking()
            .bind_to(config.bind)
            .build();
  port_ = local_port(fd_.get());
  local_addr_ = local_address(fd_.get());
  rcvbuf_ = effective_receive_buffer(fd_.get());
  msgs_.resize(max_batch_);
  iovs_.resize(max_batch_);
  addrs_.resize(max_batch_);
  control_.resize(max_batch_ * kControlBytes);
}

RecvResult UdpSource::receive(std::span<PacketSlot> out, int timeout_ms) noexcept {
  if (out.empty()) return {0, RecvStatus::kOk, 0};
  pollfd pfd{fd_.get(), POLLIN, 0};
  const int ready = ::poll(&pfd, 1, timeout_ms);
  if (ready == 0) {
    ++stats_.timeouts;
    return {0, RecvStatus::kTimeout, 0};
  }
  if (ready < 0) {
    if (errno == EINTR) return {0, RecvStatus::kInterrupted, EINTR};
    ++stats_.errors;
    return {0, RecvStatus::kError, errno};
  }

  const std::size_t n = std::min(out.size(), max_batch_);
  for (std::size_t i = 0; i < n; ++i) {
    iovs_[i] = iovec{out[i].buffer.data(), out[i].buffer.size()};
    msghdr& h = msgs_[i].msg_hdr;
    h.msg_name = &addrs_[i];
    h.msg_namelen = sizeof(sockaddr_in);
    h.msg_iov = &iovs_[i];
    h.msg_iovlen = 1;
    h.msg_control = control_.data() + i * kControlBytes;
    h.msg_controllen = kControlBytes;
    h.msg_flags = 0;
    msgs_[i].msg_len = 0;
  }
  const int got = ::recvmmsg(fd_.get(), msgs_.data(), static_cast<unsigned>(n), MSG_DONTWAIT, nullptr);
  if (got < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK) {  // readiness without data (e.g. a checksum drop)
      ++stats_.timeouts;
      return {0, RecvStatus::kTimeout, 0};
    }
    if (errno == EINTR) return {0, RecvStatus::kInterrupted, EINTR};
    ++stats_.errors;
    return {0, RecvStatus::kError, errno};
  }

  Nanos fallback_ns = 0;
  const ClockPair read = clock_pair_now();  // the batch's receive stamps on CLOCK_MONOTONIC too
  for (std::size_t i = 0; i < static_cast<std::size_t>(got); ++i) {
    PacketSlot& slot = out[i];
    const msghdr& h = msgs_[i].msg_hdr;
    slot.size = std::min<std::size_t>(msgs_[i].msg_len, slot.buffer.size());
    slot.truncated = (h.msg_flags & MSG_TRUNC) != 0;
    slot.src_addr = ntohl(addrs_[i].sin_addr.s_addr);
    slot.src_port = ntohs(addrs_[i].sin_port);
    const ReceiveControl control = read_receive_control(h);
    slot.rx_ns = control.kernel_rx_ns;
    if (control.rxq_dropped) stats_.kernel_drops = *control.rxq_dropped;
    slot.dst_addr = control.dst_addr.value_or(local_addr_);
    slot.dst_port = port_;
    slot.ip_udp_header_size = 0;
    if (slot.rx_ns == 0) {
      if (fallback_ns == 0) fallback_ns = vehicle_now_ns();
      slot.rx_ns = fallback_ns;
      ++stats_.missing_timestamps;
    }
    slot.rx_mono_ns = monotonic_receive_ns(slot.rx_ns, read.vehicle_minus_monotonic(), read.monotonic_ns);
    if (slot.truncated) ++stats_.truncated;
    stats_.bytes += slot.size;
  }
  stats_.packets += static_cast<std::uint64_t>(got);
  ++stats_.batches;
  return {static_cast<std::size_t>(got), RecvStatus::kOk, 0};
}

}  // namespace sensor_rig::lidar
