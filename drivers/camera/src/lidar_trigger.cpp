#include "sensor_rig/drivers/camera/lidar_trigger.hpp"

#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>

#include "sensor_rig/common/log.hpp"

namespace sensor_rig::drivers {
namespace {

constexpr Nanos kApproachNs = 2'000'000;   // wake this early, predict again with fresher samples
constexpr Nanos kSpinNs = 200'000;         // the last stretch is a busy wait (sleep overshoots)
constexpr Nanos kMaxSleepNs = 20'000'000;  // re-predict (and check stop) at least this often
constexpr Nanos kLateNs = 1'000'000;

void sleep_until_realtime(Nanos t) {
  const timespec ts{static_cast<time_t>(t / 1'000'000'000), static_cast<long>(t % 1'000'000'000)};
  // Absolute CLOCK_REALTIME: the aim is vehicle time, and a step of the clock moves the wake-up with it.
  while (::clock_nanosleep(CLOCK_REALTIME, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

std::string ms(Nanos ns) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", static_cast<double>(ns) * 1e-6);
  return buf;
}

}  // namespace

LidarTrigger::LidarTrigger(std::string name, LidarTriggerConfig cfg, timesync::SweepPhaseConfig phase)
    : name_(std::move(name)),
      cfg_(std::move(cfg)),
      latency_ns_(static_cast<Nanos>(std::llround(cfg_.latency_us * 1000.0))),
      phase_(phase) {}

LidarTrigger::~LidarTrigger() { stop(); }

std::size_t LidarTrigger::add(std::function<bool()> trigger) {
  members_.push_back(Member{std::move(trigger), {}, {}, 0});
  return members_.size() - 1;
}

void LidarTrigger::start(int realtime_priority) {
  if (thread_.joinable()) return;
  stop_.store(false);
  started_ns_.store(vehicle_now_ns());
  thread_ = std::thread([this] { run(); });
  (void)pthread_setname_np(thread_.native_handle(), ("trg:" + name_).substr(0, 15).c_str());
  if (realtime_priority > 0) {
    sched_param sp{};
    sp.sched_priority = realtime_priority;
    if (const int rc = pthread_setschedparam(thread_.native_handle(), SCHED_FIFO, &sp); rc != 0)
      log::warn("camera", name_ + ": trigger thread SCHED_FIFO refused (" + std::strerror(rc) + ")");
  }
}

void LidarTrigger::stop() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

Nanos LidarTrigger::tick_before(Nanos t, std::size_t member) const {
  std::lock_guard lock(mutex_);
  return member < members_.size() ? members_[member].exposures.before(t) : 0;
}

void LidarTrigger::observe_sweep(std::span<const timesync::SweepSample> samples) noexcept {
  if (samples.empty()) return;
  std::lock_guard lock(mutex_);
  phase_.observe(samples);
  for (const auto& s : samples) newest_sample_ns_ = std::max(newest_sample_ns_, s.t_ns);
  settle(newest_sample_ns_);
}

void LidarTrigger::settle(Nanos newest) noexcept {
  const Nanos period = phase_.period_ns();
  // The interpolation needs samples past the crossing: ~crossing_halfwidth of a turn (+ margin).
  const Nanos cover = period > 0 ? period / 16 + 1'000'000 : 10'000'000;
  while (!pending_.empty()) {
    const Pending& p = pending_.front();
    if (newest < p.target + cover) break;
    if (const auto actual = phase_.crossing_near(cfg_.azimuth_deg, p.target)) {
      for (std::size_t i = 0; i < members_.size() && i < p.exposures.size(); ++i)
        if (p.exposures[i] != 0) members_[i].phase_error.add(std::abs(p.exposures[i] - *actual));
    } else if (newest < p.target + (period > 0 ? period : 100'000'000) + cover) {
      break;  // the samples may still come with the next scan (the crossing sat at its cut)
    } else {
      ++figures_.unmeasured;  // a gap in the LIDAR's packets around it, or a re-acquired phase
    }
    pending_.pop_front();
  }
}

bool LidarTrigger::wait_until(Nanos aim) {
  for (;;) {
    if (stop_.load()) return false;
    const Nanos now = vehicle_now_ns();
    if (now >= aim) return true;
    if (aim - now > kSpinNs) {
      sleep_until_realtime(std::min(aim - kSpinNs, now + kMaxSleepNs));
    } else {
      while (vehicle_now_ns() < aim) {
      }
      return true;
    }
  }
}

void LidarTrigger::fire(Nanos target, Nanos aim) {
  // Back to back: each member's exposure starts at its own trigger call (+ latency), so a group's
  // stamps differ by the calls before it (its spread, measured).
  Pending p{target, std::vector<Nanos>(members_.size(), 0)};
  Nanos first = 0, last = 0;
  for (std::size_t i = 0; i < members_.size(); ++i) {
    const Nanos called = vehicle_now_ns();
    if (i == 0) first = called;
    if (!members_[i].trigger()) continue;
    p.exposures[i] = called + latency_ns_;
    last = called;
  }
  std::lock_guard lock(mutex_);
  ++figures_.triggers;
  if (first - aim > kLateNs) ++figures_.late;
  bool any = false;
  for (std::size_t i = 0; i < members_.size(); ++i) {
    if (p.exposures[i] == 0) {
      ++members_[i].refused;
      continue;
    }
    members_[i].exposures.add(p.exposures[i]);
    any = true;
  }
  if (members_.size() > 1 && last != 0) spread_.add(last - first);
  if (any) pending_.push_back(std::move(p));
  if (pending_.size() > 64) {  // the LIDAR's samples stopped coming: never measured
    pending_.pop_front();
    ++figures_.unmeasured;
  }
}

void LidarTrigger::run() {
  Nanos last_target = 0;
  while (!stop_.load()) {
    const Nanos now = vehicle_now_ns();
    std::optional<Nanos> target;
    {
      std::lock_guard lock(mutex_);
      const Nanos period = phase_.period_ns();
      // A crossing sooner than the latency cannot be hit; the one just fired is not fired twice.
      Nanos after = now + latency_ns_;
      if (last_target != 0 && period > 0) after = std::max(after, last_target + period / 2);
      target = phase_.next_crossing(cfg_.azimuth_deg, after, now);
      if (!target && figures_.predicting) ++figures_.prediction_lost;
      figures_.predicting = target.has_value();
    }
    if (!target) {
      sleep_until_realtime(now + 10'000'000);  // no prediction: no trigger (counted, in status)
      continue;
    }
    const Nanos aim = *target - latency_ns_;
    if (aim - now > kApproachNs) {
      // Sleep towards it, then predict again: the newest scan may have moved it.
      sleep_until_realtime(std::min(aim - kApproachNs, now + kMaxSleepNs));
      continue;
    }
    if (!wait_until(aim)) break;
    fire(*target, aim);
    last_target = *target;
  }
}

LidarTriggerFigures LidarTrigger::figures(std::size_t member) const {
  std::lock_guard lock(mutex_);
  LidarTriggerFigures f = figures_;
  f.sweep = phase_.status(vehicle_now_ns());
  f.members = members_.size();
  if (member < members_.size()) {
    const auto& m = members_[member];
    f.refused = m.refused;
    f.measured = m.phase_error.count();
    f.error_p50_ns = m.phase_error.percentile(0.5);
    f.error_p99_ns = m.phase_error.percentile(0.99);
    f.error_max_ns = m.phase_error.max();
  }
  f.spread_p50_ns = spread_.percentile(0.5);
  f.spread_p99_ns = spread_.percentile(0.99);
  f.spread_max_ns = spread_.max();
  return f;
}

void LidarTrigger::add_status(dds::DriverStatus& s, std::size_t member) const {
  const auto f = figures(member);
  s.add("trigger_lidar", cfg_.lidar);
  s.add("trigger_azimuth_deg", std::to_string(cfg_.azimuth_deg));
  s.add("trigger_latency_us", std::to_string(cfg_.latency_us));
  s.add("trigger_sweep", timesync::to_string(f.sweep.state));
  s.add("trigger_sweep_hz", std::to_string(f.sweep.rate_hz));
  s.add_number("triggers", f.triggers);
  s.add_number("triggers_refused", f.refused);
  s.add_number("triggers_late", f.late);
  s.add_number("trigger_prediction_lost", f.prediction_lost);
  s.add_number("phase_measured", f.measured);
  s.add_number("phase_unmeasured", f.unmeasured);
  s.add("phase_error_p50_ms", ms(f.error_p50_ns));
  s.add("phase_error_p99_ms", ms(f.error_p99_ns));
  s.add("phase_error_max_ms", ms(f.error_max_ns));
  if (f.members > 1) {  // a group (stereo pair): one tick, each member's call in turn
    s.add("trigger_group", name_);
    s.add_number("trigger_members", f.members);
    s.add("trigger_spread_p50_ms", ms(f.spread_p50_ns));
    s.add("trigger_spread_p99_ms", ms(f.spread_p99_ns));
    s.add("trigger_spread_max_ms", ms(f.spread_max_ns));
  }
  // No prediction after a start-up grace: the camera is not triggered (a real one sends nothing).
  if (!f.predicting && vehicle_now_ns() - started_ns_.load() > 2'000'000'000 && s.level == dds::Level::kOk) {
    s.level = dds::Level::kWarn;
    s.message = std::string("not triggered: no sweep prediction from lidar ") + cfg_.lidar + " (" +
                timesync::to_string(f.sweep.state) + ")";
  }
}

}  // namespace sensor_rig::drivers
