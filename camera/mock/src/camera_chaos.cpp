#include "sensor_rig/camera/mock/camera_chaos.hpp"

#include <algorithm>
#include <cmath>

namespace sensor_rig::camera::mock {

ChaosArgs chaos_from_env(const std::string& device) {
  return ChaosArgs{faults::chaos_plan_path(), device, faults::chaos_truth_path(device)};
}

CameraSchedule::CameraSchedule(const std::string& plan_path, const std::string& device)
    : CameraSchedule(plan_path.empty() ? faults::Plan{} : faults::read_plan(plan_path), device) {}

CameraSchedule::CameraSchedule(const faults::Plan& plan, const std::string& device) : epoch_mono_ns_(plan.epoch_mono_ns) {
  for (auto& e : plan.for_device(device)) {
    const auto c = e.device_class();
    if (c == faults::DeviceClass::kCamera || c == faults::DeviceClass::kV4l2) events_.push_back(std::move(e));
  }
}

const faults::FaultEvent* CameraSchedule::active(std::string_view kind, double t_s) const noexcept {
  for (const auto& e : events_) {
    if (e.kind != kind) continue;
    const bool whole_run = kind == "camera.never_answers" && e.duration_s <= 0;
    if (whole_run ? t_s >= e.at_s : e.active_at(t_s)) return &e;
  }
  return nullptr;
}

bool CameraSchedule::has(std::string_view kind) const noexcept {
  return std::any_of(events_.begin(), events_.end(), [kind](const auto& e) { return e.kind == kind; });
}

Nanos CameraSchedule::vehicle_ns(double t_s) const noexcept {
  const Nanos mono = epoch_mono_ns_ + static_cast<Nanos>(std::llround(t_s * 1e9));
  return mono + clock_pair_now().vehicle_minus_monotonic();
}

std::string_view to_string(PtpState s) noexcept {
  switch (s) {
    case PtpState::kInitializing: return "Initializing";
    case PtpState::kFaulty: return "Faulty";
    case PtpState::kDisabled: return "Disabled";
    case PtpState::kListening: return "Listening";
    case PtpState::kMaster: return "Master";
    case PtpState::kSlave: return "Slave";
    case PtpState::kUncalibrated: return "Uncalibrated";
  }
  return "?";
}

namespace {
PtpState parse_state(std::string_view s) {
  for (auto v : {PtpState::kInitializing, PtpState::kFaulty, PtpState::kDisabled, PtpState::kListening, PtpState::kMaster,
                 PtpState::kSlave, PtpState::kUncalibrated})
    if (faults::same_choice(s, to_string(v))) return v;
  return PtpState::kFaulty;  // a state the model does not know: the camera's servo reports a fault
}
constexpr Nanos kS = 1'000'000'000;
}  // namespace

PtpView ptp_at(const CameraSchedule& s, double t_s, bool ptp_enabled) noexcept {
  if (!ptp_enabled) return {PtpState::kDisabled, 0};
  const auto* e = s.active("camera.ptp", t_s);
  if (e == nullptr) return {PtpState::kSlave, static_cast<Nanos>(kTaiUtcOffsetS * 1e9)};
  const Nanos tai = static_cast<Nanos>(std::llround(e->number("tai_offset_s", kTaiUtcOffsetS) * 1e9));
  const Nanos step = static_cast<Nanos>(std::llround(e->number("step_ms", 0) * 1e6));
  const std::string state = e->text("state", "Master");
  if (!faults::same_choice(state, "cold_start")) return {parse_state(state), tai + step};
  // A cold start: the clock counts from power-on (1970 + uptime) while it listens for a master,
  // is stepped to the master's TAI (off by step_ms) while the servo converges, then locks.
  const double into = (t_s - e->at_s) / std::max(e->duration_s, 1e-9);
  if (into < 1.0 / 3) return {PtpState::kListening, -s.vehicle_ns(e->at_s)};
  if (into < 2.0 / 3) return {PtpState::kUncalibrated, tai + step};
  return {PtpState::kSlave, tai};
}

ExposureFaults::Step ExposureFaults::step(const CameraSchedule& s, double t_s, std::uint64_t frame, std::uint32_t register_us) {
  Step r{register_us, false, nullptr};
  for (const auto& e : s.events()) {
    if (e.kind != "camera.exposure_change" || e.at_s > t_s || !applied_.insert(e.id).second) continue;
    r.us = static_cast<std::uint32_t>(std::clamp(e.number("us", register_us), 1.0, 1e7));
    r.write = true;
    r.began = &e;
    if (auto_id_ != 0) auto_base_us_ = r.us;  // auto exposure varies around the new value
  }
  if (const auto* a = s.active("camera.auto_exposure", t_s)) {
    if (auto_id_ != a->id) {
      auto_id_ = a->id;
      auto_base_us_ = r.us;
      r.began = a;
    }
    // splitmix64 of (event, frame): a different exposure each frame, the same on every run.
    std::uint64_t z = a->id * 0x9e3779b97f4a7c15ULL + frame;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    z ^= z >> 31;
    const double factor = 0.5 + static_cast<double>(z % 1001) / 1000.0;
    r.us = static_cast<std::uint32_t>(std::max(1.0, std::round(auto_base_us_ * factor)));
    r.write = true;
  } else if (auto_id_ != 0) {
    auto_id_ = 0;
    r.us = auto_base_us_;
    r.write = true;
  }
  return r;
}

CameraTruth::CameraTruth(const std::string& path, const std::string& device, std::string_view device_class, std::string_view model,
                         std::string_view clock)
    : writer_(path, truth::Header{device, std::string(device_class), std::string(model), "/sensors/camera/" + device + "/image_raw",
                                  "frame", std::string(clock)}) {}

void CameraTruth::frame(std::int64_t unit, Nanos acq_ns, Nanos dev_ns, Nanos tx_ns, truth::Fate fate, std::uint64_t fault, Nanos exposure_ns) {
  std::uint64_t seq = 0;
  {
    std::lock_guard lock(mutex_);
    seq = part_seq_++;
  }
  writer_.unit(truth::UnitRecord{unit, acq_ns, dev_ns, 1, exposure_ns});
  writer_.part(truth::PartRecord{seq, unit, acq_ns, dev_ns, fate == truth::Fate::kNotSent ? 0 : tx_ns, fate, fault});
}

bool CameraTruth::fault(const faults::FaultEvent& e, Nanos at_ns, Nanos until_ns, std::int64_t unit, const std::string& detail) {
  {
    std::lock_guard lock(mutex_);
    if (!faults_.insert(e.id).second) return false;
  }
  writer_.fault(truth::FaultRecord{e.id, e.kind, at_ns, until_ns, unit, detail});
  writer_.flush();  // fault lines are rare: on disk at once, for a checker reading while the rig runs
  return true;
}

void CameraTruth::flush() { writer_.flush(); }

std::int64_t FrameUnits::unit(std::uint64_t frame_id) noexcept {
  if (frame_id <= last_) ++epoch_;  // the 16-bit id wrapped (65535 -> 1)
  last_ = frame_id;
  return epoch_ * 65536 + static_cast<std::int64_t>(frame_id & 0xffff);
}

}  // namespace sensor_rig::camera::mock
