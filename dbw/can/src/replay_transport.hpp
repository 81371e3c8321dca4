#pragma once
#include <fstream>
#include <memory>
#include <string>

#include "sensor_rig/dbw/can/candump.hpp"
#include "sensor_rig/dbw/can/transport.hpp"

namespace sensor_rig::dbw::can {

// A candump -L log as a FrameLog.
class CandumpFrameLog final : public FrameLog {
 public:
  explicit CandumpFrameLog(const std::string& path);
  bool next(LoggedFrame& out) override;
  [[nodiscard]] std::uint64_t malformed() const override { return reader_->malformed(); }

 private:
  std::ifstream in_;
  std::unique_ptr<CandumpReader> reader_;
};

// Replay at recorded timing: receive() hands out the log's frames when their time (relative to the
// first frame, divided by the rate) has come, each stamped with its recorded receive time; kClosed
// at the end. Sent frames are counted and dropped (nothing is on the other side).
class ReplayTransport final : public Transport {
 public:
  // rate 1 = real time, 0 = no waiting; delay_ns: the first frame that long after the first receive().
  ReplayTransport(std::unique_ptr<FrameLog> log, std::string name, double rate, Nanos delay_ns = 0);
  IoStatus send(const Frame& f) noexcept override;
  IoStatus receive(RxFrame& out, int timeout_ms) noexcept override;
  [[nodiscard]] int poll_fd() const noexcept override { return -1; }
  [[nodiscard]] std::string name() const override { return name_; }

 private:
  std::unique_ptr<FrameLog> log_;
  std::string name_;
  double rate_;
  Nanos delay_ns_;
  LoggedFrame next_;
  bool pending_ = false;
  bool ended_ = false;
  Nanos first_log_ns_ = -1;
  Nanos start_mono_ns_ = 0;
};

}  // namespace sensor_rig::dbw::can
