#pragma once
#include <string>

#include "sensor_rig/common/unique_fd.hpp"
#include "sensor_rig/dbw/can/transport.hpp"

namespace sensor_rig::dbw::can {

class SocketCanTransport final : public Transport {
 public:
  explicit SocketCanTransport(const std::string& iface);  // throws TransportError
  IoStatus send(const Frame& f) noexcept override;
  IoStatus receive(RxFrame& out, int timeout_ms) noexcept override;
  [[nodiscard]] int poll_fd() const noexcept override { return fd_.get(); }
  [[nodiscard]] std::string name() const override { return "socketcan:" + iface_; }
  [[nodiscard]] bool fd_capable() const noexcept { return fd_capable_; }
  // Whether socket(AF_CAN) works here; errno in *err otherwise (EAFNOSUPPORT: no CAN in the kernel).
  static bool available(int* err = nullptr) noexcept;

 private:
  std::string iface_;
  UniqueFd fd_;
  bool fd_capable_ = false;
};

}  // namespace sensor_rig::dbw::can
