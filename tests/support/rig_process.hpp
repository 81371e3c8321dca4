#pragma once
// Helpers for tests that run the real `rig` binary in separate processes: ports, temp dirs, popen.
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "dds_domain_lease.hpp"
#include "test_data.hpp"

namespace sensor_rig::test {

inline std::filesystem::path test_data() { return data_dir(); }

// A port of `type` (SOCK_DGRAM, SOCK_STREAM) on loopback that no other test takes while this
// process runs, free at the time of the call, for a `rig` child to bind. A port the kernel handed
// out (bind to port 0) was the kernel's to hand out again: between the call and the child's bind,
// another process's socket (a DDS participant, any unbound send) got it ("bind 127.0.0.1:52965:
// Address already in use", a fresh-clone run of 2026-11-29). So the port comes from below the
// kernel's ephemeral range (32768-60999) and below DDS's (7400 + 250 * domain + ...): [4100, 5300),
// and it is leased as a DDS domain is (dds_domain_lease.hpp: an abstract unix socket per port,
// freed when the process ends however it ends, no file left).
inline int free_loopback_port(int type) {
  constexpr int kFirst = 4100, kCount = 1200;
  static std::mutex m;
  static std::vector<int> leases;  // held until the process exits
  std::lock_guard lock(m);
  const int start = static_cast<int>((static_cast<unsigned>(::getpid()) * 7919U) % kCount);
  for (int i = 0; i < kCount; ++i) {
    const int port = kFirst + (start + i) % kCount;
    const int lease = take_test_lease("sensor-rig-test-port-" + std::to_string(port));
    if (lease < 0) continue;
    const int fd = ::socket(AF_INET, type | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    const bool free = fd >= 0 && ::bind(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a) == 0;
    if (fd >= 0) ::close(fd);
    if (!free) {
      ::close(lease);
      continue;
    }
    leases.push_back(lease);
    return port;
  }
  throw std::runtime_error("no free port on loopback in [4100, 5300)");
}
inline int free_udp_port() { return free_loopback_port(SOCK_DGRAM); }
inline int free_tcp_port() { return free_loopback_port(SOCK_STREAM); }

// A fresh temporary directory, removed by the destructor.
struct TempDir {
  std::filesystem::path path;
  TempDir() {
    char tmpl[] = "/tmp/rig-test-XXXXXX";
    path = ::mkdtemp(tmpl);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  std::string write(const std::string& name, const std::string& text) const {
    const auto p = path / name;
    std::ofstream(p) << text;
    return p.string();
  }
};

// Runs a command, returns (exit code, stdout).
inline std::pair<int, std::string> run(const std::string& cmd) {
  std::string out;
  FILE* f = ::popen(cmd.c_str(), "r");
  if (f == nullptr) return {-1, out};
  char buf[4096];
  while (std::fgets(buf, sizeof buf, f) != nullptr) out += buf;
  const int st = ::pclose(f);
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, out};
}

}  // namespace sensor_rig::test
