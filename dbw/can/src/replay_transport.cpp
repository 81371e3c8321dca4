// Replay at recorded timing: receive() hands out the log's frames when their time (relative to
// the first frame, divided by the rate) has come. Sent frames are counted and dropped.
#include "replay_transport.hpp"

#include <poll.h>

#include "sensor_rig/common/log.hpp"

namespace sensor_rig::dbw::can {

CandumpFrameLog::CandumpFrameLog(const std::string& path) : in_(path) {
  if (!in_) throw TransportError("candump:" + path + ": cannot open");
  reader_ = std::make_unique<CandumpReader>(in_);
}

bool CandumpFrameLog::next(LoggedFrame& out) {
  LogRecord r;
  if (!reader_->next(r)) return false;
  out.stamp = r.stamp;
  out.frame = r.frame;
  return true;
}

ReplayTransport::ReplayTransport(std::unique_ptr<FrameLog> log, std::string name, double rate, Nanos delay_ns)
    : log_(std::move(log)), name_(std::move(name)), rate_(rate), delay_ns_(delay_ns) {
  if (!(rate >= 0.0)) throw TransportError(name_ + ": rate must be >= 0");
  if (delay_ns < 0) throw TransportError(name_ + ": delay must be >= 0");
}

IoStatus ReplayTransport::send(const Frame& /*f*/) noexcept {
  ++stats_.sent;
  return IoStatus::kOk;
}

IoStatus ReplayTransport::receive(RxFrame& out, int timeout_ms) noexcept {
  if (!pending_) {
    if (ended_ || !log_->next(next_)) {
      stats_.rx_dropped = log_->malformed();
      if (!ended_) {
        const std::string why = log_->error();
        if (!why.empty()) log::error("can", name_ + ": " + why);
      }
      ended_ = true;
      return IoStatus::kClosed;
    }
    pending_ = true;
    if (first_log_ns_ < 0) {
      first_log_ns_ = next_.stamp;
      start_mono_ns_ = monotonic_now_ns() + delay_ns_;
    }
  }
  if (rate_ > 0.0 || delay_ns_ > 0) {
    const auto offset = rate_ > 0.0 ? static_cast<Nanos>(static_cast<double>(next_.stamp - first_log_ns_) / rate_) : 0;
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
  ++stats_.received;
  if (out.frame.error) note_error_frame(out.frame);
  return IoStatus::kOk;
}

}  // namespace sensor_rig::dbw::can
