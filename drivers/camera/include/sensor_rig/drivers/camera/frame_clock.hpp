#pragma once
// Exposure start of a frame in vehicle time, from what the source measured (camera/ returns
// device time + host times; this is the "source -> timesync" step):
// - device ticks (GigE): timesync's robust estimator, fed (device time, leader-packet arrival)
//   every frame; mapped device time, never the arrival time alone (host fallback until locked);
// - CLOCK_MONOTONIC (V4L2): plus the realtime-monotonic offset sampled at this frame;
// - software trigger: the exposure start the device reported, once its ticks are mapped (PTP
//   time as it is); until then the vehicle time of the trigger tick that exposed it.
// Every device stamp (PTP, mapped ticks) is checked against the frame's arrival: an exposure start
// after the first packet arrived, or more than the arrival window before it, is the clock's error
// (a camera that won the PTP election, a wrong timescale, a clock step not yet confirmed by the
// mapper): the frame falls back to the mapped ticks, else the arrival minus the exposure, counted.
// A device clock step inside the window (seconds, milliseconds) is caught by the mapper's pending
// deviation: arrivals earlier than its line allows (the clock stepped forward, or CLOCK_REALTIME
// stepped back) fall back to the arrival at once, counted, until the jump is confirmed and the line
// re-seeded (issue 27 item 8). Arrivals later than the line by up to the mapper's late_shift_max_ns
// are a held network as much as a clock stepped back (one-way timing cannot tell them apart for
// late_confirm_ns): the line's stamp is kept, the exposure a held frame really had, and once
// kStepSamples agree it is `doubtful` (flagged: for a real step back it is the step off). A late
// shift the host announced (realtime_step: CLOCK_REALTIME stepped forward) is no held network: it
// falls back to the arrival at once as before, and the mapper confirms it at the normal pace; so is
// one within late_confirm_ns of a PTP lock change (the frames' domain went to or from kVehicle: the
// camera lost or found its master, whose step its clock took), told to the mapper as well.
// A topic's stamps never go backwards when CLOCK_REALTIME is stepped back (timesync's
// MonotonicStamps: held, then slewed out), trigger ticks included: a triggered camera switches
// between its ticks and its mapped exposures, and one filter for both keeps the topic monotonic.
#include <cstdint>
#include <deque>

#include "sensor_rig/camera/frame.hpp"
#include "sensor_rig/timesync/clock_mapper.hpp"
#include "sensor_rig/timesync/monotonic_stamps.hpp"

namespace sensor_rig::drivers {

// kTriggerTick: a triggered frame before its device clock is mapped (trigger call + latency);
// kTriggerExposure: after, the exposure start it reported, mapped.
enum class StampSource : std::uint8_t { kDeviceMapped, kHostFallback, kMonotonic, kVehicle, kTriggerTick, kTriggerExposure };
const char* to_string(StampSource s) noexcept;

struct FrameStamp {
  Nanos vehicle_ns = 0;
  StampSource source = StampSource::kHostFallback;
  // The exposure start the device reported, in vehicle time (its ticks mapped, PTP, V4L2): also
  // for a frame stamped with its trigger tick; 0 while the device's clock mapping is not locked.
  Nanos device_exposure_ns = 0;
  // The stamp carries more than kSlewFlagNs of a CLOCK_REALTIME step back that MonotonicStamps
  // holds and slews out: it is later than vehicle time by that much, knowingly (the node flags the
  // topic unsynchronized meanwhile: the stamp no longer names the exposure).
  bool slewed = false;
  // The device's stamp was found wrong and replaced (outside the arrival window, or its clock
  // stepped and the mapper has not confirmed the new line yet): counted in rejected().
  bool replaced = false;
  // The frames arrive later than the device's clock (its line) says, consistently, and the mapper
  // has not taken it for a step yet: a held network (the stamp is right) or the clock stepped back
  // by up to late_shift_max_ns (the stamp is that step off). Kept, flagged (the node says
  // `stamp_sync: unsynchronized` as for `slewed`); late_shift_ns() says by how much.
  bool doubtful = false;
  // Stamped from a device clock mapping whose floor too few recent frames saw (FrameClock::floor()):
  // the frames mostly arrive late by the receiving thread's delay, so the line may be late by it
  // too (a first prompt frame at +1.2 ms and none better for 5 s: every stamp 1.2 ms late, said
  // locked). Kept, flagged, as `doubtful`.
  bool floor_unseen = false;
};
// A correction beyond this (the camera stamp bound of rig chaos) makes a stamp `slewed`.
inline constexpr Nanos kSlewFlagNs = 1'000'000;

class FrameClock {
 public:
  // exposure_ns: known delay from exposure start to the first packet beyond transport (the
  // estimator's envelope is the minimum arrival delay).
  explicit FrameClock(Nanos exposure_ns = 0);
  // `tick_ns`: vehicle time of the software trigger tick that exposed the frame (0: none).
  FrameStamp stamp(const camera::FrameMeta& m, Nanos tick_ns = 0) noexcept;
  [[nodiscard]] timesync::ClockMapperStatus status(Nanos now) const { return mapper_.status(now); }
  // The instant whose latest trigger tick exposed this frame: its first packet less the exposure
  // (the packet leaves at exposure end). Not the arrival: when exposure + delivery exceed the
  // trigger period the next tick has fired by then (issue 27 item 12: stamps one period late, two
  // frames on one tick).
  // A free-running camera whose clock mapping is locked (or in holdover) says when it exposed,
  // whatever the network did: its mapped exposure (and a slack for the mapping) where that is
  // earlier. By the arrival alone, a frame held longer than the trigger period (111 ms at 10 Hz)
  // came after the next tick and took it: stamps a period late, unflagged (rig chaos seed 7 with
  // drawn parameters, the LIDAR-triggered corner_front_left).
  [[nodiscard]] Nanos trigger_reference(const camera::FrameMeta& m) const noexcept;
  [[nodiscard]] const timesync::MonotonicStampsStatus& monotonic() const noexcept { return monotonic_.status(); }
  // CLOCK_REALTIME was stepped (the caller's RealtimeStepDetector; 0: not): a step back is absorbed;
  // the mapper is told with the next frame (its arrival is the host time after the step), so that
  // arrivals later by a step forward are not taken for a held network.
  void realtime_step(Nanos step_ns) noexcept {
    monotonic_.realtime_step(step_ns);
    if (step_ns != 0) host_step_ns_ = step_ns;
  }
  // How much later than the device's clock the frames arrived at the last `doubtful` stamp (ns).
  [[nodiscard]] Nanos late_shift_ns() const noexcept { return late_shift_ns_; }
  // A (re)opened device: its tick counter may have restarted, its exposure time changed.
  void reset(Nanos exposure_ns);
  // Device stamps (PTP or mapped ticks) found outside the frame's arrival window and replaced
  // (issue 27 items 7, 8): how many, when the last was (vehicle time), and by how much.
  struct Rejected {
    std::uint64_t count = 0;
    std::uint64_t steps = 0;   // of them: while the mapper held an unconfirmed device clock step (item 8)
    Nanos last_ns = 0;
    Nanos last_error_ns = 0;   // rejected stamp - (arrival - exposure)
  };
  [[nodiscard]] const Rejected& rejected() const noexcept { return rejected_; }
  // The mapping's floor as of the last mapped stamp: in how many of the newest buckets it was seen.
  [[nodiscard]] timesync::ClockMapper::FloorSupport floor() const noexcept { return floor_; }

 private:
  FrameStamp device_stamp(const camera::FrameMeta& m, Nanos tick_ns) noexcept;
  // What the mapper's pending deviation means for this frame's stamp (see frame_clock.cpp).
  struct Doubt {
    bool refuse = false;    // the line's stamp is refused (an unconfirmed step)
    bool doubtful = false;  // the line's stamp is kept but may be the step off (flag it)
  };
  [[nodiscard]] Doubt doubt(const timesync::ClockMapper::Deviation& d, Nanos now) const noexcept;
  [[nodiscard]] bool ptp_changed_recently(Nanos now) const noexcept;
  // A late shift pending after a PTP lock change is the camera's step: told to the mapper (as a host
  // step would be) so that it confirms it at the normal pace, not after late_confirm_ns.
  void announce_ptp_step(Nanos now) noexcept;
  // Feeds the mapper (device time, exposure start by the arrival): with the frame's own exposure
  // where the source reports it a frame or two later (FrameMeta::exposure_seq), else the latest.
  void observe(const camera::FrameMeta& m, Nanos device) noexcept;
  struct Pending {
    std::uint64_t seq;
    Nanos device;
    Nanos first_rx;
  };

  timesync::ClockMapper mapper_;
  timesync::MonotonicStamps monotonic_;  // the topic's stamps across realtime steps (kept over reopens)
  Nanos exposure_ns_;
  Rejected rejected_;
  std::deque<Pending> pending_;  // frames waiting for their exposure (sources that report it)
  bool exposures_reported_ = false;  // the source told a frame's exposure since the (re)open
  Nanos host_step_ns_ = 0;        // a CLOCK_REALTIME step not told to the mapper yet
  Nanos announced_step_ns_ = 0;   // the last step told to the mapper, and when (host time)
  Nanos announced_at_ns_ = 0;
  Nanos late_shift_ns_ = 0;
  timesync::ClockMapper::FloorSupport floor_{};
  bool have_domain_ = false;         // the last frame's time domain (a PTP lock change: to/from kVehicle)
  camera::TimeDomain domain_ = camera::TimeDomain::kDeviceTicks;
  Nanos ptp_changed_at_ns_ = 0;      // host time of the last PTP lock change (0: none)
};

}  // namespace sensor_rig::drivers
