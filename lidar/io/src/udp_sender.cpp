#include "sensor_rig/lidar/udp_sender.hpp"

#include <algorithm>
#include <arpa/inet.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace sensor_rig::lidar {

UdpSender::UdpSender(std::span<const Endpoint> destinations, int send_buffer_bytes, std::size_t max_batch) {
  if (destinations.empty()) throw std::invalid_argument("udp sender: no destination");
  if (max_batch == 0 || max_batch > 1024) throw std::invalid_argument("udp sender: max_batch must be in 1..1024");
  for (const Endpoint& ep : destinations) {
    if (ep.port == 0) throw std::invalid_argument("udp sender: destination " + ep.host + " needs a port");
    dests_.push_back(resolve(ep));
  }
  fd_ = UdpSocketBuilder{}.send_buffer(send_buffer_bytes).build();
  msgs_.resize(max_batch);
  iovs_.resize(max_batch);
  ctrl_.resize(max_batch);
}

std::uint32_t UdpSender::destination_addr(std::size_t i) const noexcept {
  return i < dests_.size() ? ntohl(dests_[i].sin_addr.s_addr) : 0;
}

SendResult UdpSender::send(std::span<const std::byte> data, std::size_t destination) noexcept {
  const OutDatagram one{data, destination};
  return send_batch(std::span<const OutDatagram>(&one, 1));
}

SendResult UdpSender::send_batch(std::span<const OutDatagram> batch) noexcept {
  SendResult result;
  std::size_t next = 0;
  while (next < batch.size()) {
    const std::size_t n = std::min(batch.size() - next, msgs_.size());
    for (std::size_t i = 0; i < n; ++i) {
      const OutDatagram& d = batch[next + i];
      const std::size_t dest = d.destination < dests_.size() ? d.destination : 0;
      iovs_[i] = iovec{const_cast<std::byte*>(d.data.data()), d.data.size()};
      msghdr& h = msgs_[i].msg_hdr;
      h = msghdr{};
      h.msg_name = &dests_[dest];
      h.msg_namelen = sizeof(sockaddr_in);
      h.msg_iov = &iovs_[i];
      h.msg_iovlen = 1;
      if (d.source_addr != 0) {
        h.msg_control = ctrl_[i].data();
        h.msg_controllen = ctrl_[i].size();
        cmsghdr* c = CMSG_FIRSTHDR(&h);
        c->cmsg_level = IPPROTO_IP;
        c->cmsg_type = IP_PKTINFO;
        c->cmsg_len = CMSG_LEN(sizeof(in_pktinfo));
        in_pktinfo info{};
        info.ipi_spec_dst.s_addr = htonl(d.source_addr);
        std::memcpy(CMSG_DATA(c), &info, sizeof info);
      }
    }
    const int rc = ::sendmmsg(fd_.get(), msgs_.data(), static_cast<unsigned>(n), 0);
    ++stats_.batches;
    if (rc < 0) {
      if (errno == EINTR) continue;
      // The first datagram failed: count it and move past it so one bad datagram cannot stall us.
      if (result.error == 0) result.error = errno;
      ++stats_.errors;
      ++next;
      continue;
    }
    if (rc == 0) break;  // cannot happen for n >= 1; guards against spinning
    for (int i = 0; i < rc; ++i) stats_.bytes += batch[next + static_cast<std::size_t>(i)].data.size();
    stats_.packets += static_cast<std::uint64_t>(rc);
    result.sent += static_cast<std::size_t>(rc);
    next += static_cast<std::size_t>(rc);
  }
  return result;
}

}  // namespace sensor_rig::lidar
