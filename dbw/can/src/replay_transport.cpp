// candump -L replay at recorded timing: receive() hands out the log's frames when their time
// (relative to the first frame, divided by the rate) has come. Sent frames are counted and dropped.
#include "replay_transport.hpp"

#include <poll.h>

namespace sensor_rig::dbw::can {

ReplayTransport::ReplayTransport(const std::string& path, double rate) : path_(path), rate_(rate), in_(path) {
  if (!in_) throw TransportError("candump:" + path + ": cannot open");
  if (!(rate >= 0.0)) throw TransportError("candump: rate must be >= 0");
  reader_ = std::make_unique<CandumpReader>(in_);
}

IoStatus ReplayTransport::send(const Frame& /*f*/) noexcept {
  ++stats_.sent;
  return IoStatus::kOk;
}

IoStatus ReplayTransport::receive(RxFrame& out, int timeout_ms) noexcept {
  if (!pending_) {
    if (!reader_->next(next_)) {
      stats_.rx_dropped = reader_->malformed();
      return IoStatus::kClosed;
    }
    pending_ = true;
    if (first_log_ns_ < 0) {
      first_log_ns_ = next_.stamp;
      start_mono_ns_ = monotonic_now_ns();
    }
  }
  if (rate_ > 0.0) {
    const auto offset = static_cast<Nanos>(static_cast<double>(next_.stamp - first_log_ns_) / rate_);
    const Nanos due = start_mono_ns_ + offset;
    const Nanos now = monotonic_now_ns();
    if (due > now) {
      const Nanos wait_ns = due - now;
      if (timeout_ms >= 0 && wait_ns > static_cast<Nanos>(timeout_ms) * 1'000'000LL) {
        ::poll(nullptr, 0, timeout_ms);
        return IoStatus::kTimeout;
      }
      timespec ts{static_cast<time_t>(wait_ns / 1'000'000'000LL), static_cast<long>(wait_ns % 1'000'000'000LL)};
      ::clock_nanosleep(CLOCK_MONOTONIC, 0, &ts, nullptr);
    }
  }
  pending_ = false;
  out.frame = next_.frame;
  out.stamp = next_.stamp;
  iface_ = next_.iface;
  ++stats_.received;
  if (out.frame.error) note_error_frame(out.frame);
  return IoStatus::kOk;
}

}  // namespace sensor_rig::dbw::can
