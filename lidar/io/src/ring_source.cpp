#include "sensor_rig/lidar/ring_source.hpp"

#include <arpa/inet.h>
#include <linux/if_ether.h>
#include <linux/if_packet.h>
#include <net/if.h>
#include <poll.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>
#include <utility>

#include "sensor_rig/common/socket_options.hpp"
#include "sensor_rig/lidar/packet_filter.hpp"
#include "sensor_rig/lidar/udp_frame.hpp"

namespace sensor_rig::lidar {
namespace {

constexpr int kLinktypeIpv4 = 228;  // the frames start at the IPv4 header (SOCK_DGRAM)
constexpr std::size_t kPage = 4096;
constexpr std::size_t kFrameBytes = 2048;  // TPACKET_V3 ignores frames but checks frame_nr against it
constexpr Nanos kStatsPeriodNs = 100'000'000;

[[noreturn]] void fail(const std::string& what) { throw std::system_error(errno, std::generic_category(), what); }

const tpacket_block_desc* block_at(const std::byte* ring, std::size_t block_bytes, std::size_t i) noexcept {
  return reinterpret_cast<const tpacket_block_desc*>(ring + i * block_bytes);
}

std::uint32_t block_status(const std::byte* ring, std::size_t block_bytes, std::size_t i) noexcept {
  auto* bd = const_cast<tpacket_block_desc*>(block_at(ring, block_bytes, i));
  return __atomic_load_n(&bd->hdr.bh1.block_status, __ATOMIC_ACQUIRE);  // the kernel's writes before it
}

}  // namespace

RingSource::RingSource(const RingSourceConfig& config) : config_(config), reassembler_(config.reassembly) {
  if (config.block_bytes < (128u << 10) || config.block_bytes % kPage != 0)
    throw std::invalid_argument("packet source: block_bytes must be a multiple of 4096 and >= 131072");
  if (config.block_count < 2 || config.block_count > 4096)
    throw std::invalid_argument("packet source: block_count must be in 2..4096");
  if (config.retire_timeout_ms < 1 || config.retire_timeout_ms > 1000)
    throw std::invalid_argument("packet source: retire_timeout_ms must be in 1..1000");
  if (config.port == 0) throw std::invalid_argument("packet source: port must be non-zero");
  if (config.second_port == config.port)
    throw std::invalid_argument("packet source: the second port must differ from the data port");
  const unsigned ifindex = ::if_nametoindex(config.interface.c_str());
  if (config.interface.empty() || ifindex == 0)
    throw std::runtime_error("packet source: network interface '" + config.interface + "' not found");

  // Protocol 0: the socket receives nothing until bind(), after the filter and the ring are set.
  fd_ = UniqueFd(::socket(AF_PACKET, SOCK_DGRAM | SOCK_CLOEXEC, 0));
  if (!fd_) fail("socket(AF_PACKET) (needs CAP_NET_RAW)");
  set_socket_option(fd_.get(), SOL_PACKET, PACKET_VERSION, TPACKET_V3, "PACKET_VERSION TPACKET_V3");
  const auto program = build_sensor_filter({config.port, config.sensor_host, config.second_port});
  sock_fprog prog{static_cast<unsigned short>(program.size()), const_cast<sock_filter*>(program.data())};
  if (::setsockopt(fd_.get(), SOL_SOCKET, SO_ATTACH_FILTER, &prog, sizeof prog) != 0) fail("setsockopt SO_ATTACH_FILTER");
  // Our own sends (a mock on the same host) would otherwise come twice on loopback.
  (void)try_socket_option(fd_.get(), SOL_PACKET, PACKET_IGNORE_OUTGOING, 1);

  tpacket_req3 req{};
  req.tp_block_size = static_cast<unsigned>(config.block_bytes);
  req.tp_block_nr = static_cast<unsigned>(config.block_count);
  req.tp_frame_size = kFrameBytes;
  req.tp_frame_nr = static_cast<unsigned>(config.block_bytes / kFrameBytes * config.block_count);
  req.tp_retire_blk_tov = static_cast<unsigned>(config.retire_timeout_ms);
  req.tp_feature_req_word = 0;
  if (::setsockopt(fd_.get(), SOL_PACKET, PACKET_RX_RING, &req, sizeof req) != 0) fail("setsockopt PACKET_RX_RING");
  ring_bytes_ = config.block_bytes * config.block_count;
  void* map = ::mmap(nullptr, ring_bytes_, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_POPULATE, fd_.get(), 0);
  if (map == MAP_FAILED) {
    ring_bytes_ = 0;
    fail("mmap packet ring");
  }
  ring_ = static_cast<std::byte*>(map);

  sockaddr_ll addr{};
  addr.sll_family = AF_PACKET;
  addr.sll_protocol = htons(ETH_P_IP);
  addr.sll_ifindex = static_cast<int>(ifindex);
  if (::bind(fd_.get(), reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const int e = errno;
    ::munmap(ring_, ring_bytes_);
    ring_ = nullptr;
    errno = e;
    fail("bind packet socket to " + config.interface);
  }
  last_stats_ns_ = monotonic_now_ns();
}

RingSource::RingSource(RingSource&& o) noexcept
    : config_(std::move(o.config_)),
      fd_(std::move(o.fd_)),
      ring_(std::exchange(o.ring_, nullptr)),
      ring_bytes_(std::exchange(o.ring_bytes_, 0)),
      block_(o.block_),
      packets_left_(o.packets_left_),
      next_(std::exchange(o.next_, nullptr)),
      reassembler_(std::move(o.reassembler_)),
      last_stats_ns_(o.last_stats_ns_),
      stats_(o.stats_) {}

RingSource& RingSource::operator=(RingSource&& o) noexcept {
  if (this != &o) {
    if (ring_ != nullptr) ::munmap(ring_, ring_bytes_);
    config_ = std::move(o.config_);
    fd_ = std::move(o.fd_);
    ring_ = std::exchange(o.ring_, nullptr);
    ring_bytes_ = std::exchange(o.ring_bytes_, 0);
    block_ = o.block_;
    packets_left_ = o.packets_left_;
    next_ = std::exchange(o.next_, nullptr);
    reassembler_ = std::move(o.reassembler_);
    last_stats_ns_ = o.last_stats_ns_;
    stats_ = o.stats_;
  }
  return *this;
}

RingSource::~RingSource() {
  if (ring_ != nullptr) ::munmap(ring_, ring_bytes_);  // before the fd closes (UniqueFd member)
}

void RingSource::refresh_kernel_stats() noexcept {
  tpacket_stats_v3 st{};
  socklen_t len = sizeof st;
  if (::getsockopt(fd_.get(), SOL_PACKET, PACKET_STATISTICS, &st, &len) != 0) {
    ++stats_.errors;
    return;
  }
  stats_.ring_packets += st.tp_packets;  // the kernel adds its drops into tp_packets
  stats_.ring_drops += st.tp_drops;
  stats_.ring_freeze_q += st.tp_freeze_q_cnt;
  last_stats_ns_ = monotonic_now_ns();
}

void RingSource::release_block() noexcept {
  auto* bd = reinterpret_cast<tpacket_block_desc*>(ring_ + block_ * config_.block_bytes);
  __atomic_store_n(&bd->hdr.bh1.block_status, TP_STATUS_KERNEL, __ATOMIC_RELEASE);  // our reads before it
  block_ = (block_ + 1) % config_.block_count;
  next_ = nullptr;
  packets_left_ = 0;
  ++stats_.blocks;
}

bool RingSource::deliver(const std::byte* frame, PacketSlot& slot) noexcept {
  tpacket3_hdr h{};
  std::memcpy(&h, frame, sizeof h);
  sockaddr_ll ll{};
  std::memcpy(&ll, frame + TPACKET_ALIGN(sizeof(tpacket3_hdr)), sizeof ll);
  if (ll.sll_pkttype == PACKET_OUTGOING) return false;  // kernels without PACKET_IGNORE_OUTGOING
  if (h.tp_snaplen < h.tp_len) {  // the ring cut it (a frame larger than a block): cannot be used
    ++stats_.truncated;
    return false;
  }
  Nanos rx = static_cast<Nanos>(h.tp_sec) * 1'000'000'000LL + h.tp_nsec;
  if (h.tp_sec == 0) {
    rx = vehicle_now_ns();
    ++stats_.missing_timestamps;
  }
  const std::span<const std::byte> ip(frame + h.tp_net, h.tp_snaplen);
  // The timeout runs on CLOCK_MONOTONIC (the drain's time: a host clock step neither expires
  // datagrams in flight nor keeps dead ones); the datagram keeps the kernel's stamp.
  const ReassemblyResult r = reassembler_.push(ip, rx, drain_mono_ns_);
  if (r.status != ReassemblyStatus::kNotFragment && r.status != ReassemblyStatus::kComplete) return false;
  const UdpFrame f = parse_udp_frame(kLinktypeIpv4, r.datagram);
  // Non-first fragments of any datagram of the sensor pass the kernel filter: the port decides here.
  const bool second = config_.second_port != 0 && f.dst_port == config_.second_port;
  if (f.status != FrameStatus::kOk || (f.dst_port != config_.port && !second) ||
      (config_.sensor_host != 0 && f.src_ip != config_.sensor_host)) {
    ++stats_.filtered;
    return false;
  }
  slot.size = std::min(f.payload.size(), slot.buffer.size());
  slot.truncated = f.payload.size() > slot.buffer.size();
  std::memcpy(slot.buffer.data(), f.payload.data(), slot.size);
  slot.rx_ns = r.rx_ns;
  slot.rx_mono_ns = monotonic_receive_ns(r.rx_ns, drain_clocks_.vehicle_minus_monotonic(), drain_clocks_.monotonic_ns);
  slot.src_addr = f.src_ip;
  slot.src_port = f.src_port;
  slot.dst_addr = f.dst_ip;
  slot.dst_port = f.dst_port;
  const auto headers = static_cast<std::size_t>(f.payload.data() - r.datagram.data());  // IPv4 (+ options) + UDP
  slot.ip_udp_header_size = static_cast<std::uint8_t>(std::min(headers, slot.ip_udp_header.size()));
  std::memcpy(slot.ip_udp_header.data(), r.datagram.data(), slot.ip_udp_header_size);
  if (slot.truncated) ++stats_.truncated;
  ++stats_.packets;
  if (second) ++stats_.second_port_packets;
  stats_.bytes += slot.size;
  return true;
}

std::size_t RingSource::drain(std::span<PacketSlot> out) noexcept {
  std::size_t n = 0;
  while (n < out.size()) {
    if (next_ == nullptr) {
      if ((block_status(ring_, config_.block_bytes, block_) & TP_STATUS_USER) == 0) break;  // still the kernel's
      const auto* bd = block_at(ring_, config_.block_bytes, block_);
      packets_left_ = bd->hdr.bh1.num_pkts;
      next_ = reinterpret_cast<const std::byte*>(bd) + bd->hdr.bh1.offset_to_first_pkt;
    }
    while (packets_left_ > 0 && n < out.size()) {
      std::uint32_t next_offset = 0;
      std::memcpy(&next_offset, next_ + offsetof(tpacket3_hdr, tp_next_offset), sizeof next_offset);
      if (deliver(next_, out[n])) ++n;
      next_ += next_offset;
      --packets_left_;
    }
    if (packets_left_ == 0) release_block();
  }
  return n;
}

RecvResult RingSource::receive(std::span<PacketSlot> out, int timeout_ms) noexcept {
  if (out.empty()) return {0, RecvStatus::kOk, 0};
  const Nanos start = monotonic_now_ns();
  if (start - last_stats_ns_ >= kStatsPeriodNs) refresh_kernel_stats();
  // A fragment that did not come within the timeout will not come: counted, its memory freed.
  // Monotonic: on CLOCK_REALTIME a host step forward gave up every datagram in flight (issue 26).
  reassembler_.expire(start);
  stats_.reassembly = reassembler_.counters();
  for (bool polled = false;; polled = true) {
    drain_clocks_ = clock_pair_now();  // the drain's receive stamps on CLOCK_MONOTONIC too
    drain_mono_ns_ = polled ? drain_clocks_.monotonic_ns : start;
    const std::size_t n = drain(out);
    stats_.reassembly = reassembler_.counters();
    if (n > 0) return {n, RecvStatus::kOk, 0};
    int wait_ms = timeout_ms;
    if (timeout_ms >= 0) {  // frames that were all filtered or incomplete do not restart the wait
      wait_ms = timeout_ms - static_cast<int>((monotonic_now_ns() - start) / 1'000'000);
      if (wait_ms <= 0 && polled) {
        ++stats_.timeouts;
        return {0, RecvStatus::kTimeout, 0};
      }
      wait_ms = std::max(wait_ms, 0);
    }
    pollfd pfd{fd_.get(), POLLIN | POLLERR, 0};
    const int ready = ::poll(&pfd, 1, wait_ms);
    if (ready == 0 && (block_status(ring_, config_.block_bytes, block_) & TP_STATUS_USER) == 0) {
      ++stats_.timeouts;
      refresh_kernel_stats();
      return {0, RecvStatus::kTimeout, 0};
    }
    if (ready < 0) {
      if (errno == EINTR) return {0, RecvStatus::kInterrupted, EINTR};
      ++stats_.errors;
      return {0, RecvStatus::kError, errno};
    }
    if ((pfd.revents & POLLERR) != 0) {  // pending socket error: read it so poll does not spin
      int err = 0;
      socklen_t len = sizeof err;
      (void)::getsockopt(fd_.get(), SOL_SOCKET, SO_ERROR, &err, &len);
      ++stats_.errors;
      return {0, RecvStatus::kError, err};
    }
  }
}

}  // namespace sensor_rig::lidar
