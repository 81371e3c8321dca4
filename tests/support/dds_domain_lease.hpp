#pragma once
// A DDS domain no other test on this host uses while this process runs.
//
// Tests that run at the same time (ctest -j) and publish the rig's fixed topics (/vehicle/dbw/cmd,
// /vehicle/state, ...) must not share a domain: a status reader then reads the other test's bridge
// and a sender drives it. Deriving the domain from the pid (100 + pid % 100) collided in CI. A lease
// is a bound abstract unix socket "sensor-rig-test-dds-domain-N": the kernel lets one process bind a
// name, frees it when the process ends however it ends, and leaves no file behind.
//
//   const int domain = sensor_rig::test::lease_dds_domain();   // held until the process exits
//
// Each call leases another domain. Children the test starts use the domain it passes them; they
// need no lease of their own since the test outlives them.
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstddef>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sensor_rig::test {

// Leased domains lie in [kFirstLeasedDomain, kLastLeasedDomain]; fixed domains in tests stay below.
// Cyclone's default port mapping (7400 + 250 * domain + offsets) fits 16 bits up to domain 232.
inline constexpr int kFirstLeasedDomain = 100;
inline constexpr int kLastLeasedDomain = 229;

// The lease of `name` among this host's processes: a socket bound to it in the abstract unix
// namespace (one binder at a time, freed when the process ends however it ends, no file); its fd,
// to keep open while the lease is held, or -1 when another process holds it.
inline int take_test_lease(const std::string& name) {
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path + 1, name.data(), name.size());  // sun_path[0] == 0: abstract namespace
  const auto len = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + 1 + name.size());
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), len) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// One leased domain, held while the object lives (the test's whole run for lease_dds_domain()).
class DdsDomainLease {
 public:
  // The lease of `domain`, or an object without one (held() false) when another process holds it.
  static DdsDomainLease try_take(int domain) {
    DdsDomainLease l;
    const int fd = take_test_lease("sensor-rig-test-dds-domain-" + std::to_string(domain));
    if (fd < 0) return l;
    l.fd_ = fd;
    l.domain_ = domain;
    return l;
  }
  // The first free domain of the range, tried from a place that depends on the pid so parallel tests
  // rarely try the same one first; waits up to `wait_ms` for one to be freed before it throws.
  static DdsDomainLease take(int wait_ms = 5000) {
    constexpr int kCount = kLastLeasedDomain - kFirstLeasedDomain + 1;
    const int start = static_cast<int>(::getpid()) % kCount;
    for (int waited = 0;; waited += 10) {
      for (int i = 0; i < kCount; ++i) {
        auto l = try_take(kFirstLeasedDomain + (start + i) % kCount);
        if (l.held()) return l;
      }
      if (waited >= wait_ms) break;
      ::usleep(10'000);
    }
    throw std::runtime_error("no free DDS test domain in [" + std::to_string(kFirstLeasedDomain) + ", " +
                             std::to_string(kLastLeasedDomain) + "]");
  }
  DdsDomainLease(DdsDomainLease&& o) noexcept : fd_(o.fd_), domain_(o.domain_) { o.fd_ = -1; }
  DdsDomainLease& operator=(DdsDomainLease&& o) noexcept {
    std::swap(fd_, o.fd_);
    std::swap(domain_, o.domain_);
    return *this;
  }
  DdsDomainLease(const DdsDomainLease&) = delete;
  DdsDomainLease& operator=(const DdsDomainLease&) = delete;
  ~DdsDomainLease() {
    if (fd_ >= 0) ::close(fd_);
  }
  [[nodiscard]] bool held() const { return fd_ >= 0; }
  [[nodiscard]] int domain() const { return domain_; }

 private:
  DdsDomainLease() = default;
  int fd_ = -1;
  int domain_ = -1;
};

// A domain of this process's own until it exits.
inline int lease_dds_domain() {
  static std::vector<DdsDomainLease> held;  // never given back: children may still use the domain
  held.push_back(DdsDomainLease::take());
  return held.back().domain();
}

}  // namespace sensor_rig::test
