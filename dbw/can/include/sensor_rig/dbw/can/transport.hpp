#pragma once
// CAN transports behind one interface: SocketCAN (CAN 2.0 + FD, kernel timestamps, error frames,
// bus-off), AF_UNIX SOCK_SEQPACKET carrying the kernel `struct can_frame`/`canfd_frame` bytes
// (socketpair, or a listening "bus" socket several processes connect to), and candump log replay.
// Hot path: send/receive return an IoStatus, never throw. Opening throws TransportError.
#include <atomic>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/can/frame.hpp"

namespace sensor_rig::dbw::can {

struct TransportError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

enum class IoStatus : std::uint8_t {
  kOk,
  kTimeout,     // nothing within the wait
  kWouldBlock,  // send buffer full: the frame was NOT queued (never retried later: no stale frames)
  kBusOff,      // controller is bus-off: frame refused
  kClosed,      // peer gone / end of log
  kInvalid,     // frame malformed (bad length) or not representable on this transport
  kError,       // other OS error (errno kept in stats)
};
[[nodiscard]] const char* to_string(IoStatus s) noexcept;

enum class BusState : std::uint8_t { kActive, kWarning, kPassive, kBusOff };
[[nodiscard]] const char* to_string(BusState s) noexcept;

struct RxFrame {
  Frame frame;
  Nanos stamp = 0;  // kernel receive time (CLOCK_REALTIME), or the log time for replay
};

// A statistic one thread updates while others read it (relaxed atomics: counts, no ordering).
template <class T>
class StatValue {
 public:
  StatValue(T v = T{}) noexcept : v_(v) {}  // NOLINT(google-explicit-constructor): reads as a plain number
  StatValue(const StatValue& o) noexcept : v_(o.load()) {}
  StatValue& operator=(const StatValue& o) noexcept { return *this = o.load(); }
  StatValue& operator=(T v) noexcept {
    v_.store(v, std::memory_order_relaxed);
    return *this;
  }
  StatValue& operator++() noexcept {
    v_.fetch_add(1, std::memory_order_relaxed);
    return *this;
  }
  operator T() const noexcept { return load(); }  // NOLINT(google-explicit-constructor)
  [[nodiscard]] T load() const noexcept { return v_.load(std::memory_order_relaxed); }

 private:
  std::atomic<T> v_;
};

// Updated by the sending and the receiving thread (the bridge sends from two threads, receives on one).
struct TransportStats {
  StatValue<std::uint64_t> sent = 0;
  StatValue<std::uint64_t> received = 0;
  StatValue<std::uint64_t> send_refused = 0;  // would_block / bus_off / invalid
  StatValue<std::uint64_t> rx_dropped = 0;    // malformed wire records, kernel drops
  StatValue<std::uint64_t> error_frames = 0;
  StatValue<std::uint64_t> bus_off_events = 0;
  StatValue<std::uint64_t> options_refused = 0;  // optional socket options the kernel refused (each logged)
  StatValue<int> last_errno = 0;
};

// What an error frame says about the controller (linux/can/error.h classes).
struct ErrorInfo {
  bool bus_off = false;
  bool restarted = false;
  bool passive = false;
  bool warning = false;
  bool back_to_active = false;
};
[[nodiscard]] ErrorInfo classify_error_frame(const Frame& f) noexcept;
// An error frame as a controller would report the event (for mocks and tests).
[[nodiscard]] Frame make_error_frame(bool bus_off, bool restarted) noexcept;

class Transport {
 public:
  virtual ~Transport() = default;
  Transport() = default;
  Transport(const Transport&) = delete;
  Transport& operator=(const Transport&) = delete;

  virtual IoStatus send(const Frame& f) noexcept = 0;
  // Waits up to timeout_ms (0 = poll, <0 = forever). Error frames are delivered too (frame.error)
  // after updating the bus state.
  virtual IoStatus receive(RxFrame& out, int timeout_ms) noexcept = 0;
  // A descriptor that becomes readable when receive() has something (-1 if none).
  [[nodiscard]] virtual int poll_fd() const noexcept = 0;
  [[nodiscard]] virtual std::string name() const = 0;
  // False when the frame just sent reached no other node: a bus owner alone on its bus (the mock
  // ECU's listener before the bridge has connected). A real CAN bus does not say; it is assumed heard.
  [[nodiscard]] virtual bool last_send_heard() const noexcept { return true; }

  [[nodiscard]] BusState bus_state() const noexcept { return state_; }
  [[nodiscard]] const TransportStats& stats() const noexcept { return stats_; }

 protected:
  // Updates bus state from an error frame; returns the info.
  ErrorInfo note_error_frame(const Frame& f) noexcept;
  // Written by the receiving thread, read by senders on other threads (the bridge's DDS thread).
  std::atomic<BusState> state_{BusState::kActive};
  TransportStats stats_;
};

// Opens a transport from a spec string:
//   socketcan:IFACE          SocketCAN raw socket (CAN FD enabled, error frames, kernel timestamps)
//   unix:PATH                connect to a bus socket (SOCK_SEQPACKET) another process listens on
//   unix-listen:PATH         be the bus: accept any number of peers; what one peer sends reaches the owner and all others
//   fd:N                     an inherited SOCK_SEQPACKET descriptor (one end of a socketpair)
//   candump:FILE[@RATE[,DELAY_S]]  replay a candump -L log at recorded timing (RATE: speed factor, 0 = as fast as
//                            possible; DELAY_S: the first frame that long after the first receive(), default 0)
//   KIND:FILE[@RATE[,DELAY_S]]  replay frames from a log of a kind registered below (the `rig` executable
//                            registers `mcap`: the raw CAN channel of a `rig record --raw` file)
std::unique_ptr<Transport> open_transport(std::string_view spec);

// A recorded sequence of received frames, in order, for the replay transports: candump logs here,
// other formats from the layers above (an MCAP raw channel is read in rig/, which dbw/ sits below).
struct LoggedFrame {
  Nanos stamp = 0;  // when it was received (CLOCK_REALTIME): the replayed frame's receive stamp
  Frame frame;
};
class FrameLog {
 public:
  virtual ~FrameLog() = default;
  // The next frame; false at the end (or at the first place that cannot be read).
  virtual bool next(LoggedFrame& out) = 0;
  // Records that could not be read as frames (skipped); what stopped the log early, if anything.
  [[nodiscard]] virtual std::uint64_t malformed() const = 0;
  [[nodiscard]] virtual std::string error() const { return {}; }
  // How long after the transport opens its first frame is due unless the spec says (`@RATE,DELAY_S`):
  // time for the replaying process's subscribers to match its writers before the drive starts.
  [[nodiscard]] virtual Nanos default_delay_ns() const { return 0; }
};
// Opens FILE as a FrameLog; throws TransportError (or std::runtime_error) with the reason.
using FrameLogOpener = std::unique_ptr<FrameLog> (*)(const std::string& file);
// Makes `KIND:FILE[@RATE]` a replay transport reading FILE through `open` (at recorded timing, as
// candump:). Call before opening transports (at program start); a later call for KIND replaces it.
void register_frame_log_kind(const std::string& kind, FrameLogOpener open);

// Two connected in-process ends (socketpair AF_UNIX SOCK_SEQPACKET).
std::pair<std::unique_ptr<Transport>, std::unique_ptr<Transport>> make_socketpair();

}  // namespace sensor_rig::dbw::can
