#pragma once
// What the camera fakes need of a `rig chaos` campaign (common/fault_plan.hpp, truth_record.hpp):
// the fault events of one camera by time, the PTP clock a camera has at a moment, and its truth
// record (one unit and one part line per frame, one fault line per occurrence).
//
// Times: a plan is in seconds after its epoch (CLOCK_MONOTONIC); the truth is vehicle time
// (CLOCK_REALTIME ns), and "dev" what the camera itself says. The fakes' model of a frame: its
// exposure starts at the stamp the fake takes (Aravis: g_get_real_time at fill, the fake V4L2
// device: its frame slot), so that instant is the truth the rig's header.stamp must match.
#include <cmath>
#include <cstdint>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/fault_plan.hpp"
#include "sensor_rig/common/truth_record.hpp"

namespace sensor_rig::camera::mock {

// Where a fake finds its campaign: the plan, its own config name and its truth file. Empty plan and
// truth: no campaign (the fake behaves and writes nothing).
struct ChaosArgs {
  std::string plan;    // fault plan file (RIG_CHAOS_DIR/plan.jsonl)
  std::string device;  // the camera's config name: the plan's ">DEVICE", the truth's device
  std::string truth;   // truth record file
  [[nodiscard]] bool any() const noexcept { return !plan.empty() || !truth.empty(); }
};
// RIG_CHAOS_DIR's plan and this device's truth (both empty outside a campaign).
ChaosArgs chaos_from_env(const std::string& device);

// The camera.* and v4l2.* events of one device, by time. Immutable once built: read from any thread.
class CameraSchedule {
 public:
  CameraSchedule() = default;
  // Reads the plan file (throws std::runtime_error naming file:line); an empty path: no events.
  CameraSchedule(const std::string& plan_path, const std::string& device);
  CameraSchedule(const faults::Plan& plan, const std::string& device);

  [[nodiscard]] double seconds(Nanos mono_ns) const noexcept { return static_cast<double>(mono_ns - epoch_mono_ns_) * 1e-9; }
  [[nodiscard]] Nanos mono_ns(double t_s) const noexcept { return epoch_mono_ns_ + static_cast<Nanos>(std::llround(t_s * 1e9)); }
  [[nodiscard]] double now_s() const noexcept { return seconds(monotonic_now_ns()); }
  // The first event of `kind` active at t (camera.never_answers: from its start to the end of the run).
  [[nodiscard]] const faults::FaultEvent* active(std::string_view kind, double t_s) const noexcept;
  [[nodiscard]] bool has(std::string_view kind) const noexcept;
  [[nodiscard]] const std::vector<faults::FaultEvent>& events() const noexcept { return events_; }
  // Vehicle time of plan time t (through the current CLOCK_REALTIME - CLOCK_MONOTONIC offset).
  [[nodiscard]] Nanos vehicle_ns(double t_s) const noexcept;

 private:
  Nanos epoch_mono_ns_ = 0;
  std::vector<faults::FaultEvent> events_;
};

// SFNC PtpStatus values (the enumeration the chaos GenICam serves, as real cameras number them).
enum class PtpState : std::uint32_t { kInitializing = 0, kFaulty = 1, kDisabled = 2, kListening = 3, kMaster = 4, kSlave = 5, kUncalibrated = 6 };
std::string_view to_string(PtpState s) noexcept;
inline constexpr double kTaiUtcOffsetS = 37.0;  // TAI - UTC since 2017

// What the camera reports and what its clock says, relative to UTC (dev = UTC + offset_ns).
struct PtpView {
  PtpState state = PtpState::kDisabled;
  Nanos offset_ns = 0;
};
// The PTP model (camera/README.md "Mocks: faults"): PTP off -> Disabled, the fake's own clock (UTC);
// on without a fault -> Slave, TAI (UTC + 37 s); a camera.ptp event -> its `state`, the clock at
// TAI (tai_offset_s) + step_ms; state=cold_start -> Listening with a clock counting from power-on
// (0 at the event's start), then a step to TAI + step_ms as Uncalibrated, then Slave at TAI, in
// thirds of the event's duration.
PtpView ptp_at(const CameraSchedule& s, double t_s, bool ptp_enabled) noexcept;

// Exposure faults, applied per frame: camera.exposure_change writes its `us` once at its start (then
// the register is the camera's again: a later write by the rig holds); camera.auto_exposure varies
// it 0.5..1.5 x the value before the event, per frame (seeded by the event: the same on every run),
// and puts that value back at its end.
class ExposureFaults {
 public:
  struct Step {
    std::uint32_t us = 0;                        // the exposure of this frame
    bool write = false;                          // the register must be set to `us`
    const faults::FaultEvent* began = nullptr;   // an event that began with this frame
  };
  Step step(const CameraSchedule& s, double t_s, std::uint64_t frame, std::uint32_t register_us);

 private:
  std::set<std::uint64_t> applied_;
  std::uint64_t auto_id_ = 0;
  std::uint32_t auto_base_us_ = 0;
};

// A camera's truth record: one unit and one part line per frame, a fault line per occurrence (once
// per plan event id). Thread-safe.
class CameraTruth {
 public:
  // Throws std::runtime_error when the file cannot be created.
  CameraTruth(const std::string& path, const std::string& device, std::string_view device_class, std::string_view model,
              std::string_view clock);
  // exposure_ns: the exposure the camera reported for the frame (its chunk), 0: none.
  void frame(std::int64_t unit, Nanos acq_ns, Nanos dev_ns, Nanos tx_ns, truth::Fate fate, std::uint64_t fault = 0, Nanos exposure_ns = 0);
  // Records the occurrence once; true when it was new.
  bool fault(const faults::FaultEvent& e, Nanos at_ns, Nanos until_ns, std::int64_t unit, const std::string& detail);
  void flush();

 private:
  truth::Writer writer_;
  std::mutex mutex_;
  std::uint64_t part_seq_ = 0;
  std::set<std::uint64_t> faults_;
};

// Units are unique per device and increase: the camera's 16-bit frame id (GVSP block id, 1..65535)
// in the low 16 bits, above it a count of the camera's reboots and id wraps.
class FrameUnits {
 public:
  std::int64_t unit(std::uint64_t frame_id) noexcept;
  void reboot() noexcept { ++epoch_; last_ = 0; }

 private:
  std::int64_t epoch_ = 0;
  std::uint64_t last_ = 0;
};

}  // namespace sensor_rig::camera::mock
