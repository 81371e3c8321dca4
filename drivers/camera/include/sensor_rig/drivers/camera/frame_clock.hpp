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
// deviation: arrivals earlier than its line allows (the clock stepped forward) at once, later ones
// (stepped back, or a host delay) once kStepSamples agree; those frames fall back to the arrival
// too, counted, until the jump is confirmed and the line re-seeded (issue 27 item 8).
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
  [[nodiscard]] Nanos trigger_reference(const camera::FrameMeta& m) const noexcept {
    return m.first_rx_ns - (m.exposure_ns > 0 ? m.exposure_ns : exposure_ns_);  // the latest exposure known
  }
  [[nodiscard]] const timesync::MonotonicStampsStatus& monotonic() const noexcept { return monotonic_.status(); }
  // CLOCK_REALTIME was stepped (the caller's RealtimeStepDetector): a step back is absorbed.
  void realtime_step(Nanos step_ns) noexcept { monotonic_.realtime_step(step_ns); }
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

 private:
  FrameStamp device_stamp(const camera::FrameMeta& m, Nanos tick_ns) noexcept;
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
};

}  // namespace sensor_rig::drivers
