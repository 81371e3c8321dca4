#pragma once
#include <fstream>
#include <memory>
#include <string>

#include "sensor_rig/dbw/can/candump.hpp"
#include "sensor_rig/dbw/can/transport.hpp"

namespace sensor_rig::dbw::can {

class ReplayTransport final : public Transport {
 public:
  ReplayTransport(const std::string& path, double rate);  // rate 1 = real time, 0 = no waiting
  IoStatus send(const Frame& f) noexcept override;
  IoStatus receive(RxFrame& out, int timeout_ms) noexcept override;
  [[nodiscard]] int poll_fd() const noexcept override { return -1; }
  [[nodiscard]] std::string name() const override { return "candump:" + path_; }
  [[nodiscard]] const std::string& last_iface() const noexcept { return iface_; }

 private:
  std::string path_;
  double rate_;
  std::ifstream in_;
  std::unique_ptr<CandumpReader> reader_;
  LogRecord next_;
  bool pending_ = false;
  Nanos first_log_ns_ = -1;
  Nanos start_mono_ns_ = 0;
  std::string iface_;
};

}  // namespace sensor_rig::dbw::can
