#pragma once
#include <mutex>
#include <string>
#include <vector>

#include "sensor_rig/common/unique_fd.hpp"
#include "sensor_rig/dbw/can/transport.hpp"

namespace sensor_rig::dbw::can {

// One connected SOCK_SEQPACKET end; each record is one kernel can_frame/canfd_frame.
// Connected to a bus by path (unix:PATH), the end outlives the bus owner: a real CAN bus does not
// vanish when an ECU dies, so when the owner goes away (the mock ECU killed or restarted) the bus
// reads as bus-off (sends refused, nothing received) and the end reconnects every 100 ms; back on
// the bus it is active again. Ends without a path (fd:N, socketpair) report kClosed.
class SeqpacketTransport final : public Transport {
 public:
  SeqpacketTransport(UniqueFd fd, std::string name, std::string reconnect_path = {});
  IoStatus send(const Frame& f) noexcept override;
  IoStatus receive(RxFrame& out, int timeout_ms) noexcept override;
  [[nodiscard]] int poll_fd() const noexcept override { return fd_.get(); }
  [[nodiscard]] std::string name() const override { return name_; }
  static std::unique_ptr<Transport> connect(const std::string& path);

 private:
  bool try_reconnect() noexcept;  // receiving thread only
  UniqueFd fd_;
  std::string name_;
  std::string reconnect_path_;
  std::mutex fd_mu_;         // the receiving thread replaces fd_ while others send on it
  Nanos next_attempt_ns_ = 0;
  bool disconnected_ = false;  // the bus owner went away (receiving thread only)
};

// The bus: listens on a path; frames from any peer reach the owner (receive) and every other peer;
// frames the owner sends reach all peers.
class BusListener final : public Transport {
 public:
  explicit BusListener(const std::string& path);
  ~BusListener() override;
  IoStatus send(const Frame& f) noexcept override;
  IoStatus receive(RxFrame& out, int timeout_ms) noexcept override;
  [[nodiscard]] int poll_fd() const noexcept override { return epoll_.get(); }
  [[nodiscard]] std::string name() const override { return name_; }
  [[nodiscard]] bool last_send_heard() const noexcept override { return last_heard_; }
  [[nodiscard]] std::size_t peers() const {
    std::lock_guard<std::mutex> lock(peers_mu_);
    return peers_.size();
  }

 private:
  void accept_peers() noexcept;
  void drop_peer(int fd) noexcept;
  void relay(const Frame& f, int except_fd) noexcept;
  std::string path_;
  std::string name_;  // unix-listen:PATH
  UniqueFd listen_;
  UniqueFd epoll_;
  // send() and receive() may run on different threads: both accept, relay to and drop peers.
  mutable std::mutex peers_mu_;
  bool last_heard_ = true;  // the sending thread's
  std::vector<UniqueFd> peers_;
};

}  // namespace sensor_rig::dbw::can
