#pragma once
#include <mutex>
#include <string>
#include <vector>

#include "sensor_rig/common/unique_fd.hpp"
#include "sensor_rig/dbw/can/transport.hpp"

namespace sensor_rig::dbw::can {

// One connected SOCK_SEQPACKET end; each record is one kernel can_frame/canfd_frame.
class SeqpacketTransport final : public Transport {
 public:
  SeqpacketTransport(UniqueFd fd, std::string name);
  IoStatus send(const Frame& f) noexcept override;
  IoStatus receive(RxFrame& out, int timeout_ms) noexcept override;
  [[nodiscard]] int poll_fd() const noexcept override { return fd_.get(); }
  [[nodiscard]] std::string name() const override { return name_; }
  static std::unique_ptr<Transport> connect(const std::string& path);

 private:
  UniqueFd fd_;
  std::string name_;
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
  std::vector<UniqueFd> peers_;
};

}  // namespace sensor_rig::dbw::can
