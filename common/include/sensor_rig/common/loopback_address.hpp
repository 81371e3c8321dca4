#pragma once
// A 127.0.0.0/8 address on `lo` for as long as a lease on it lives.
//
// GigE Vision fakes need one address each (GVCP's port 3956 is per address), so the mock rig and
// the camera tests add addresses to `lo`: a change to the host that must be undone. Every address
// the rig adds is recorded in a registry (one line per holder: address, pid, the holder's start
// time) and removed when its last holder lets go: at the lease's end, on SIGINT/SIGTERM through
// the normal shutdown, or, for a holder that died without letting go (SIGKILL, a crash, a test
// killed at its timeout), by the next process that takes a lease or calls `sweep()`. Addresses
// that were on the host before the rig came are never recorded, so never removed. Several
// processes may hold the same address (a test beside `rig up`): it stays until the last lets go.
//
// The registry is one file under $RIG_STATE_DIR (default /run/sensor-rig), locked with flock for
// every change, removed with its folder when it holds no address. Addresses are changed over
// rtnetlink (root or CAP_NET_ADMIN); without the privilege `take` says why and changes nothing.
#include <optional>
#include <string>
#include <vector>

namespace sensor_rig {

class LoopbackAddress {
 public:
  // The lease on `address` (IPv4). Present on some interface already and not in the registry: a
  // lease that removes nothing. Absent: added to `lo` (/8, scope host) and recorded. nullopt, and
  // `why` says why, when it is no IPv4 address, not 127.0.0.0/8 and absent, or cannot be added.
  static std::optional<LoopbackAddress> take(const std::string& address, std::string& why);

  // Removes the addresses whose every recorded holder has died; returns them. `take` does it first.
  static std::vector<std::string> sweep();
  // The registry's file (for messages and tests).
  static std::string registry_path();

  LoopbackAddress(LoopbackAddress&& other) noexcept;
  LoopbackAddress& operator=(LoopbackAddress&& other) noexcept;
  LoopbackAddress(const LoopbackAddress&) = delete;
  LoopbackAddress& operator=(const LoopbackAddress&) = delete;
  ~LoopbackAddress();

  [[nodiscard]] const std::string& address() const { return address_; }
  // True when this lease is recorded (the rig added the address, or shares one it added).
  [[nodiscard]] bool recorded() const { return recorded_; }

 private:
  LoopbackAddress(std::string address, bool recorded) : address_(std::move(address)), recorded_(recorded) {}
  void release() noexcept;

  std::string address_;
  bool recorded_ = false;
};

// True when some interface holds the IPv4 address.
bool host_has_address(const std::string& address);

}  // namespace sensor_rig
