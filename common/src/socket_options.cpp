#include "sensor_rig/common/socket_options.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <string>
#include <system_error>

namespace sensor_rig {

void set_socket_option(int fd, int level, int opt, int value, const char* name) {
  if (::setsockopt(fd, level, opt, &value, sizeof value) != 0)
    throw std::system_error(errno, std::generic_category(), std::string("setsockopt ") + name);
}

bool try_socket_option(int fd, int level, int opt, int value) noexcept {
  return ::setsockopt(fd, level, opt, &value, sizeof value) == 0;
}

ReceiveControl read_receive_control(const msghdr& h) noexcept {
  ReceiveControl rc;
  for (cmsghdr* c = CMSG_FIRSTHDR(&h); c != nullptr; c = CMSG_NXTHDR(const_cast<msghdr*>(&h), c)) {
    if (c->cmsg_level == IPPROTO_IP && c->cmsg_type == IP_PKTINFO && c->cmsg_len >= CMSG_LEN(sizeof(in_pktinfo))) {
      in_pktinfo info{};
      std::memcpy(&info, CMSG_DATA(c), sizeof info);
      rc.dst_addr = ntohl(info.ipi_addr.s_addr);
      continue;
    }
    if (c->cmsg_level != SOL_SOCKET) continue;
    if (c->cmsg_type == SCM_TIMESTAMPNS && c->cmsg_len >= CMSG_LEN(sizeof(timespec))) {
      timespec ts{};
      std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
      rc.kernel_rx_ns = static_cast<Nanos>(ts.tv_sec) * 1'000'000'000LL + ts.tv_nsec;
    } else if (c->cmsg_type == SO_RXQ_OVFL && c->cmsg_len >= CMSG_LEN(sizeof(std::uint32_t))) {
      std::uint32_t drops = 0;
      std::memcpy(&drops, CMSG_DATA(c), sizeof drops);
      rc.rxq_dropped = drops;
    }
  }
  return rc;
}

}  // namespace sensor_rig
