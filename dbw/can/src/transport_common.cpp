#include <linux/can.h>
#include <linux/can/error.h>

#include "sensor_rig/dbw/can/transport.hpp"

namespace sensor_rig::dbw::can {

const char* to_string(IoStatus s) noexcept {
  switch (s) {
    case IoStatus::kOk: return "ok";
    case IoStatus::kTimeout: return "timeout";
    case IoStatus::kWouldBlock: return "would_block";
    case IoStatus::kBusOff: return "bus_off";
    case IoStatus::kClosed: return "closed";
    case IoStatus::kInvalid: return "invalid";
    case IoStatus::kError: return "error";
  }
  return "?";
}

const char* to_string(BusState s) noexcept {
  switch (s) {
    case BusState::kActive: return "active";
    case BusState::kWarning: return "warning";
    case BusState::kPassive: return "passive";
    case BusState::kBusOff: return "bus_off";
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
    if (state_ != BusState::kBusOff) ++stats_.bus_off_events;
    state_ = BusState::kBusOff;
  } else if (e.restarted || e.back_to_active) {
    state_ = BusState::kActive;
  } else if (e.passive && state_ != BusState::kBusOff) {
    state_ = BusState::kPassive;
  } else if (e.warning && state_ == BusState::kActive) {
    state_ = BusState::kWarning;
  }
  return e;
}

}  // namespace sensor_rig::dbw::can
