#include "sensor_rig/dbw/can/frame.hpp"

#include <linux/can.h>

#include <algorithm>
#include <cstring>

namespace sensor_rig::dbw::can {

static_assert(sizeof(can_frame) == kClassicWireSize, "struct can_frame layout");
static_assert(sizeof(canfd_frame) == kFdWireSize, "struct canfd_frame layout");

bool operator==(const Frame& a, const Frame& b) noexcept {
  return a.id == b.id && a.len == b.len && a.extended == b.extended && a.rtr == b.rtr && a.error == b.error &&
         a.fd == b.fd && a.brs == b.brs && a.esi == b.esi &&
         std::equal(a.data.begin(), a.data.begin() + (a.rtr ? 0 : a.len), b.data.begin());
}

bool valid_fd_length(std::size_t len) noexcept {
  return len <= 8 || len == 12 || len == 16 || len == 20 || len == 24 || len == 32 || len == 48 || len == 64;
}

namespace {
canid_t wire_id(const Frame& f) noexcept {
  if (f.error) return (f.id & CAN_ERR_MASK) | CAN_ERR_FLAG;
  canid_t id = f.extended ? ((f.id & CAN_EFF_MASK) | CAN_EFF_FLAG) : (f.id & CAN_SFF_MASK);
  if (f.rtr) id |= CAN_RTR_FLAG;
  return id;
}

void set_id(canid_t id, Frame& out) noexcept {
  out.error = (id & CAN_ERR_FLAG) != 0;
  out.rtr = !out.error && (id & CAN_RTR_FLAG) != 0;
  out.extended = !out.error && (id & CAN_EFF_FLAG) != 0;
  out.id = out.error ? (id & CAN_ERR_MASK) : out.extended ? (id & CAN_EFF_MASK) : (id & CAN_SFF_MASK);
}
}  // namespace

std::size_t to_wire(const Frame& f, std::span<std::uint8_t> out) noexcept {
  if (f.fd) {
    if (out.size() < kFdWireSize || f.len > kFdMaxLen || f.rtr) return 0;
    canfd_frame w{};
    w.can_id = wire_id(f);
    w.len = f.len;
    w.flags = static_cast<__u8>((f.brs ? CANFD_BRS : 0) | (f.esi ? CANFD_ESI : 0) | CANFD_FDF);
    std::memcpy(w.data, f.data.data(), f.len);
    std::memcpy(out.data(), &w, sizeof w);
    return sizeof w;
  }
  if (out.size() < kClassicWireSize || f.len > kClassicMaxLen) return 0;
  can_frame w{};
  w.can_id = wire_id(f);
  w.len = f.len;
  if (!f.rtr) std::memcpy(w.data, f.data.data(), f.len);
  std::memcpy(out.data(), &w, sizeof w);
  return sizeof w;
}

WireStatus from_wire(std::span<const std::uint8_t> in, Frame& out) noexcept {
  out = Frame{};
  if (in.size() == kClassicWireSize) {
    can_frame w{};
    std::memcpy(&w, in.data(), sizeof w);
    if (w.len > kClassicMaxLen) return WireStatus::kBadLength;
    set_id(w.can_id, out);
    out.len = w.len;
    if (!out.rtr) std::memcpy(out.data.data(), w.data, w.len);
    return WireStatus::kOk;
  }
  if (in.size() == kFdWireSize) {
    canfd_frame w{};
    std::memcpy(&w, in.data(), sizeof w);
    if (w.len > kFdMaxLen) return WireStatus::kBadLength;
    set_id(w.can_id, out);
    if (out.rtr) return WireStatus::kBadId;  // no remote frames in CAN FD
    out.fd = true;
    out.brs = (w.flags & CANFD_BRS) != 0;
    out.esi = (w.flags & CANFD_ESI) != 0;
    out.len = w.len;
    std::memcpy(out.data.data(), w.data, w.len);
    return WireStatus::kOk;
  }
  return WireStatus::kBadSize;
}

}  // namespace sensor_rig::dbw::can
