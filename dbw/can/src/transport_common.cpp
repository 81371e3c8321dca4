#include <linux/can.h>
#include <linux/can/error.h>

#include "sensor_rig/dbw/can/transport.hpp"

namespace sensor_rig::dbw::can {

const char* to_string(IoStatus s) noexcept {
  switch (s) {
    case IoStatus::ok: return "ok";
    case IoStatus::timeout: return "timeout";
    case IoStatus::would_block: return "would_block";
    case IoStatus::bus_off: return "bus_off";
    case IoStatus::closed: return "closed";
    case IoStatus::invalid: return "invalid";
    case IoStatus::error: return "error";
  }
  return "?";
}

const char* to_string(BusState s) noexcept {
  switch (s) {
    case BusState::active: return "active";
    case BusState::warning: return "warning";
    case BusState::passive: return "passive";
    case BusState::bus_off: return "bus_off";
  }
  return "?";
}

ErrorInfo classify_error_frame(const Frame& f) noexcept {
  ErrorInfo e;
  if (!f.error) return e;
  e.bus_off = (f.id & CAN_ERR_BUSOFF) != 0;
  e.restarted = (f.id & CAN_ERR_RESTARTED) != 0;
  if ((f.id & CAN_ERR_CRTL) != 0 && f.len > 1) {
    const std::uint8_t c = f.data[1];
    e.passive = (c & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0;
    e.warning = (c & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) != 0;
    e.back_to_active = (c & CAN_ERR_CRTL_ACTIVE) != 0;
  }
  return e;
}

Frame make_error_frame(bool bus_off, bool restarted) noexcept {
  Frame f;
  f.error = true;
  f.len = CAN_ERR_DLC;
  if (bus_off) f.id |= CAN_ERR_BUSOFF;
  if (restarted) f.id |= CAN_ERR_RESTARTED;
  return f;
}

ErrorInfo Transport::note_error_frame(const Frame& f) noexcept {
  const ErrorInfo e = classify_error_frame(f);
  ++stats_.error_frames;
  if (e.bus_off) {
    if (state_ != BusState::bus_off) ++stats_.bus_off_events;
    state_ = BusState::bus_off;
  } else if (e.restarted || e.back_to_active) {
    state_ = BusState::active;
  } else if (e.passive && state_ != BusState::bus_off) {
    state_ = BusState::passive;
  } else if (e.warning && state_ == BusState::active) {
    state_ = BusState::warning;
  }
  return e;
}

}  // namespace sensor_rig::dbw::can
