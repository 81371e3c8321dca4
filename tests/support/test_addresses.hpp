#pragma once
// Loopback addresses that one test process holds alone among this host's test processes.
//
// A GigE fake binds GVCP's port 3956 on its address, so two tests that run at once (ctest -j, two
// copies of one executable) must never use the same address. Derived from the pid (127.0.0.(base +
// pid % n)), they could: copies of one executable whose pids agreed mod n, and tests of different
// executables whose ranges overlapped (20..219, 100..199, 140..199, 216..225, 230..249, 240..249).
// Each address is now claimed with a test lease (dds_domain_lease.hpp: an abstract unix socket named
// after the address, freed when the process ends however it ends, no file) before it is used; the
// caller still takes it on `lo` (LoopbackAddress), which several holders may share.
//
//   const auto a = test::TestAddresses::take(216, 225, 2);   // a[0], a[1]: 127.0.0.x, 127.0.0.x+1
#include <unistd.h>

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "dds_domain_lease.hpp"

namespace sensor_rig::test {

class TestAddresses {
 public:
  // `n` consecutive addresses 127.0.0.s .. s+n-1 with lo <= s and s+n-1 <= hi, the first block
  // (tried from a place that depends on the pid) whose every address no other test process holds;
  // waits up to `wait_ms` for one to be freed, then throws.
  static TestAddresses take(int lo, int hi, int n = 1, int wait_ms = 10'000) {
    const int starts = hi - lo - n + 2;
    if (lo < 1 || hi > 254 || n < 1 || starts < 1) throw std::invalid_argument("TestAddresses: bad range");
    const int from = static_cast<int>(::getpid() % starts);
    for (int waited = 0;; waited += 10) {
      for (int i = 0; i < starts; ++i) {
        TestAddresses a;
        a.first_ = lo + (from + i) % starts;
        for (int k = 0; k < n; ++k) {
          const int fd = take_test_lease("sensor-rig-test-address-127.0.0." + std::to_string(a.first_ + k));
          if (fd < 0) break;
          a.claims_.push_back(fd);
        }
        if (static_cast<int>(a.claims_.size()) == n) return a;  // else its claims go with it
      }
      if (waited >= wait_ms) break;
      ::usleep(10'000);
    }
    throw std::runtime_error("TestAddresses: no " + std::to_string(n) + " free consecutive test addresses in 127.0.0." +
                             std::to_string(lo) + ".." + std::to_string(hi));
  }

  TestAddresses(TestAddresses&& o) noexcept : first_(o.first_), claims_(std::move(o.claims_)) { o.claims_.clear(); }
  TestAddresses& operator=(TestAddresses&& o) noexcept {
    std::swap(first_, o.first_);
    std::swap(claims_, o.claims_);
    return *this;
  }
  TestAddresses(const TestAddresses&) = delete;
  TestAddresses& operator=(const TestAddresses&) = delete;
  ~TestAddresses() {
    for (const int fd : claims_) ::close(fd);
  }

  [[nodiscard]] std::string operator[](std::size_t k) const {
    if (k >= claims_.size()) throw std::out_of_range("TestAddresses: address " + std::to_string(k) + " not taken");
    return "127.0.0." + std::to_string(first_ + static_cast<int>(k));
  }
  [[nodiscard]] std::size_t size() const { return claims_.size(); }

 private:
  TestAddresses() = default;
  int first_ = 0;
  std::vector<int> claims_;  // one lease per address
};

}  // namespace sensor_rig::test
