#include "sensor_rig/drivers/camera/lidar_trigger.hpp"

#include <pthread.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <chrono>
#include <cstring>
#include <optional>

#include "member_call.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/thread_priority.hpp"

namespace sensor_rig::drivers {
namespace {

constexpr Nanos kApproachNs = 2'000'000;   // arm this early, with the freshest prediction
constexpr Nanos kSpinNs = 200'000;         // the last stretch is a busy wait (sleep overshoots)
constexpr Nanos kMaxSleepNs = 20'000'000;  // re-predict (and check stop) at least this often
constexpr Nanos kLateNs = 1'000'000;
constexpr std::size_t kKeepTicks = 32;     // ~3 s at 10 Hz: the frames of a tick come within it
// A member's call that has not returned this long after the aim is given up on for the tick: a
// camera's trigger is a GVCP write (~1.4 ms acknowledged); a dead or reopening camera must not hold
// its partners' next shots (issue 27 item 1). Well under a 10 Hz period.
constexpr Nanos kMemberDeadlineNs = 25'000'000;
// A member still busy with an older shot when this one was aimed skips it rather than fire late.
constexpr Nanos kStaleShotNs = 1'000'000;

void sleep_until(clockid_t clock, Nanos t) {
  const timespec ts{static_cast<time_t>(t / 1'000'000'000), static_cast<long>(t % 1'000'000'000)};
  while (::clock_nanosleep(clock, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

// Towards a vehicle-time instant, on CLOCK_MONOTONIC: a CLOCK_REALTIME step during the sleep
// neither stretches it nor cuts it short (issue 27 item 11); the loop predicts again on waking.
void sleep_until_vehicle(Nanos t) {
  const Nanos left = t - vehicle_now_ns();
  if (left > 0) sleep_until(CLOCK_MONOTONIC, monotonic_now_ns() + left);
}

// The firing threads wait on CLOCK_MONOTONIC: an armed shot is at most kApproachNs away, and a
// realtime step in between must not hold a member back while another fires.
void spin_until_monotonic(Nanos t) {
  if (t - monotonic_now_ns() > kSpinNs) sleep_until(CLOCK_MONOTONIC, t - kSpinNs);
  while (monotonic_now_ns() < t) {
  }
}

void set_fifo(std::thread& t, int priority, const std::string& who) {
  if (priority <= 0) return;
  if (const auto r = try_realtime_priority(t.native_handle(), priority); !r)
    log::warn("camera", who + ": trigger thread SCHED_FIFO " + std::to_string(priority) + " refused (" + r.why_not + ")");
}

std::string ms(Nanos ns) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", static_cast<double>(ns) * 1e-6);
  return buf;
}

ErrorFigure figure_of(const ErrorHistory& h) {
  return {h.count(), h.percentile(0.5), h.percentile(0.99), h.max()};
}

void add_figure(dds::DriverStatus& s, const std::string& prefix, const ErrorFigure& f) {
  s.add(prefix + "_p50_ms", ms(f.p50_ns));
  s.add(prefix + "_p99_ms", ms(f.p99_ns));
  s.add(prefix + "_max_ms", ms(f.max_ns));
}

}  // namespace

LidarTrigger::LidarTrigger(std::string name, LidarTriggerConfig cfg, timesync::SweepPhaseConfig phase)
    : name_(std::move(name)),
      cfg_(std::move(cfg)),
      latency_ns_(static_cast<Nanos>(std::llround(cfg_.latency_us * 1000.0))),
      phase_(phase) {}

LidarTrigger::~LidarTrigger() { stop(); }

std::size_t LidarTrigger::add(std::function<bool()> trigger) {
  Member m;
  m.trigger = std::move(trigger);
  members_.push_back(std::move(m));
  return members_.size() - 1;
}

void LidarTrigger::start(int realtime_priority) {
  if (thread_.joinable()) return;
  stop_.store(false);
  std::uint64_t generation = 0;  // a restarted trigger's firing threads skip the shots before
  {
    std::lock_guard lock(shot_mutex_);
    shot_.closing = false;
    shot_.called.assign(members_.size(), 0);
    shot_.accepted.assign(members_.size(), 0);
    generation = shot_.generation;
    shot_.reported.assign(members_.size(), generation);
    shot_.busy.assign(members_.size(), 0);
    shot_.abandoned.assign(members_.size(), 0);
    shot_.taken.assign(members_.size(), 0);
    shot_.call_began.assign(members_.size(), 0);
  }
  started_ns_.store(vehicle_now_ns());
  realtime_priority_ = realtime_priority;
  for (std::size_t i = 0; i < members_.size(); ++i) start_firing_thread(i, generation);
  thread_ = std::thread([this] { run(); });
  (void)pthread_setname_np(thread_.native_handle(), ("trg:" + name_).substr(0, 15).c_str());
  set_fifo(thread_, realtime_priority, name_);
}

void LidarTrigger::start_firing_thread(std::size_t i, std::uint64_t seen) {
  Member& m = members_[i];
  m.call = std::make_shared<MemberCall>(m.trigger);
  m.thread = std::thread([this, i, seen, call = m.call] { run_member(i, seen, *call); });
  (void)pthread_setname_np(m.thread.native_handle(), ("trg" + std::to_string(i) + ":" + name_).substr(0, 15).c_str());
  set_fifo(m.thread, realtime_priority_, name_);
}

void LidarTrigger::leave_hung_calls(Nanos mono) {
  for (std::size_t i = 0; i < members_.size(); ++i) {
    Member& m = members_[i];
    const Nanos began = shot_.call_began[i];
    if (began == 0 || mono - began <= kTriggerCallHungNs) continue;
    std::erase_if(m.left_in_flight, [](const std::shared_ptr<MemberCall>& c) { return !c->in_call(); });
    if (m.left_in_flight.size() >= kMaxTriggerCallsLeft) continue;  // its shots stay skipped, refused
    if (!m.call->leave_if_in_call()) continue;  // it just returned: its thread reports it
    m.left_in_flight.push_back(m.call);
    // Left, the thread returns from the call without touching this trigger: it may outlive it. Its
    // shot was timed out and waits to be settled by the call's return: refused now.
    m.thread.detach();
    shot_.call_began[i] = 0;
    shot_.reported[i] = shot_.generation;
    {
      std::lock_guard lock(mutex_);
      ++m.refused;
      ++m.calls_left;
    }
    start_firing_thread(i, shot_.generation);  // it takes the next shot armed
  }
}

void LidarTrigger::stop() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();  // it waits for its armed shot's calls
  {
    std::lock_guard lock(shot_mutex_);
    shot_.closing = true;
  }
  shot_cv_.notify_all();
  std::vector<FiringThread> threads;  // a call hung on a dead camera is left, not waited for
  for (auto& m : members_)
    if (m.call) threads.push_back({&m.thread, m.call.get()});
  join_or_leave(threads);
}

Nanos LidarTrigger::tick_before(Nanos t, std::size_t member) const {
  std::lock_guard lock(mutex_);
  if (member >= members_.size()) return 0;
  const Member& m = members_[member];
  const Nanos by_call = t + latency_ns_;  // ticks are call + latency: compare the calls
  const Nanos recorded = m.exposures.before(by_call);
  const Nanos calling = m.calling->load();
  return calling != 0 && calling <= by_call ? std::max(recorded, calling) : recorded;
}

void LidarTrigger::observe_sweep(std::span<const timesync::SweepSample> samples) noexcept {
  if (samples.empty()) return;
  std::lock_guard lock(mutex_);
  phase_.observe(samples);
  for (const auto& s : samples) newest_sample_ns_ = std::max(newest_sample_ns_, s.t_ns);
  settle(newest_sample_ns_);
}

void LidarTrigger::add_device_error(const Tick& t, std::size_t member) noexcept {
  if (t.crossing != 0 && t.device[member] != 0) members_[member].device_error.add(std::abs(t.device[member] - t.crossing));
}

void LidarTrigger::exposed(std::size_t member, Nanos tick, Nanos device_exposure_ns) {
  if (tick == 0 || device_exposure_ns == 0) return;
  std::lock_guard lock(mutex_);
  if (member >= members_.size()) return;
  const auto it = std::find_if(ticks_.rbegin(), ticks_.rend(), [&](const Tick& t) { return t.exposures[member] == tick; });
  if (it == ticks_.rend() || it->device[member] != 0) return;  // gone, or its frame already told
  // Another tick's frame (the camera sent one without our trigger, or dropped ours): more than
  // half a turn between call and exposure cannot be this trigger's.
  const Nanos delay = device_exposure_ns - (tick - latency_ns_);
  const Nanos period = phase_.period_ns();
  if (std::abs(delay) > (period > 0 ? period / 2 : 50'000'000)) {
    ++members_[member].unmatched;
    return;
  }
  it->device[member] = device_exposure_ns;
  members_[member].to_exposure.add(delay);
  add_device_error(*it, member);
}

void LidarTrigger::settle(Nanos newest) noexcept {
  const Nanos period = phase_.period_ns();
  // The interpolation needs samples past the crossing: ~crossing_halfwidth of a turn (+ margin).
  const Nanos cover = period > 0 ? period / 16 + 1'000'000 : 10'000'000;
  for (Tick& t : ticks_) {
    if (t.settled) continue;
    if (newest < t.target + cover) break;
    if (const auto actual = phase_.crossing_near(cfg_.azimuth_deg, t.target)) {
      t.crossing = *actual;
      for (std::size_t i = 0; i < members_.size(); ++i) {
        if (t.exposures[i] == 0) continue;
        members_[i].call_error.add(std::abs(t.exposures[i] - t.crossing));
        add_device_error(t, i);
      }
    } else if (newest < t.target + (period > 0 ? period : 100'000'000) + cover) {
      break;  // the samples may still come with the next scan (the crossing sat at its cut)
    } else {
      ++figures_.unmeasured;  // a gap in the LIDAR's packets around it, or a re-acquired phase
    }
    t.settled = true;
  }
}

void LidarTrigger::run_member(std::size_t i, std::uint64_t seen, MemberCall& call) {
  for (;;) {
    Nanos aim = 0;
    bool fire_it = false;  // not skipped as stale (see below)
    {
      std::unique_lock lock(shot_mutex_);
      shot_cv_.wait(lock, [&] { return shot_.generation != seen || shot_.closing; });
      if (shot_.generation == seen) return;  // closing with nothing armed
      seen = shot_.generation;
      aim = shot_.aim_mono;
      // Given up on before this thread even took it (counted refused): not fired.
      fire_it = shot_.abandoned[i] == 0 && (shot_.busy[i] == 0 || monotonic_now_ns() <= aim + kStaleShotNs);
      shot_.taken[i] = fire_it ? 1 : 0;
      if (fire_it) shot_.call_began[i] = aim;
    }
    // Armed: fired even when stop() came meanwhile, so that no member fires alone. A shot whose
    // aim passed while this member's camera held it in an older call is skipped, not fired late.
    // One whose thread merely woke late (a loaded host) fires: its partners woke late too, and a
    // skipped shot is a lost frame (it cost sync_sets_test 1-8 refused triggers in 4 s under load).
    Nanos called = 0;
    bool accepted = false;
    if (fire_it) {
      spin_until_monotonic(aim);
      called = vehicle_now_ns();
      std::atomic<Nanos>& calling = *members_[i].calling;
      calling.store(called + latency_ns_);
      const auto answer = call.call();
      if (!answer) return;  // left by stop() during (or before) the call: this trigger may be gone
      accepted = *answer;
      if (!accepted) {  // no frame comes for it: not a tick to match one to
        std::lock_guard lock(mutex_);
        calling.store(0);
      }
    }
    bool late = false;  // the trigger thread gave up waiting for this call
    {
      std::lock_guard lock(shot_mutex_);
      late = shot_.generation != seen || shot_.abandoned[i] != 0;
      shot_.call_began[i] = 0;
      if (shot_.generation == seen) {  // the trigger thread still waits for this shot
        shot_.called[i] = called;
        shot_.accepted[i] = accepted ? 1 : 0;
      }
      shot_.reported[i] = seen;
    }
    shot_cv_.notify_all();
    if (late && called != 0) settle_late_call(i, seen, called, accepted);
    // Its frame may come before the shot closes (the trigger thread waits up to 25 ms for a partner
    // that does not answer): the tick is there for it now. Before, while stereo_right was slow to
    // open, every stereo_left frame (10 ms after its call) was matched to the tick before: masked
    // by the mapped exposure until a held network put the mapping in holdover, then published
    // 100 ms early, unflagged.
    if (!late && accepted) {
      std::lock_guard lock(mutex_);
      members_[i].exposures.add(called + latency_ns_);
      members_[i].calling->store(0);  // recorded: matched from the ticks now
    }
  }
}

void LidarTrigger::settle_late_call(std::size_t i, std::uint64_t generation, Nanos called, bool accepted) {
  std::lock_guard lock(mutex_);
  if (!accepted) {
    ++members_[i].refused;
    return;
  }
  // Taken, only late (the camera answered after the deadline): its frame comes for this tick.
  const Nanos exposure = called + latency_ns_;
  members_[i].exposures.add(exposure);
  members_[i].calling->store(0);
  members_[i].accepted_mono.add(monotonic_now_ns());
  const auto it = std::find_if(ticks_.begin(), ticks_.end(), [&](const Tick& t) { return t.generation == generation; });
  if (it != ticks_.end()) it->exposures[i] = exposure;
}

void LidarTrigger::fire(Nanos target, Nanos aim) {
  // Every member's firing thread calls its camera's trigger at the same instant: a group's stamps
  // (each its own call + latency) differ by the threads' wake-ups, not by a camera's round trip.
  // The trigger thread waits for the calls up to a deadline: a member whose camera does not answer
  // misses its tick (counted), its partners do not.
  Tick t{0, target, std::vector<Nanos>(members_.size(), 0), std::vector<Nanos>(members_.size(), 0), 0, false};
  Nanos first = 0;  // the earliest call (late wake-up), and the accepted calls' span (the spread)
  Nanos lo = 0, hi = 0;
  std::size_t accepted = 0;
  std::vector<char> timed_out(members_.size(), 0);
  std::vector<char> in_flight(members_.size(), 0);  // timed out in this shot's call (not an older one's)
  // Taken before the shot is let go (lock order shot_mutex_, mutex_): a late call's settlement
  // (settle_late_call) then finds this tick.
  std::unique_lock figures_lock(mutex_, std::defer_lock);
  {
    std::unique_lock lock(shot_mutex_);
    shot_.aim_mono = aim - clock_pair_now().vehicle_minus_monotonic();
    std::fill(shot_.called.begin(), shot_.called.end(), 0);
    std::fill(shot_.accepted.begin(), shot_.accepted.end(), 0);
    std::fill(shot_.abandoned.begin(), shot_.abandoned.end(), 0);
    std::fill(shot_.taken.begin(), shot_.taken.end(), 0);
    leave_hung_calls(monotonic_now_ns());
    for (std::size_t i = 0; i < members_.size(); ++i) shot_.busy[i] = shot_.reported[i] != shot_.generation ? 1 : 0;
    const std::uint64_t gen = ++shot_.generation;
    t.generation = gen;
    shot_cv_.notify_all();
    // From the aim, or from now for a crossing fired late: the members get their full time.
    const Nanos waited_from = std::max(shot_.aim_mono, monotonic_now_ns());
    const auto deadline = std::chrono::steady_clock::time_point(std::chrono::nanoseconds(waited_from + kMemberDeadlineNs));
    (void)shot_cv_.wait_until(lock, deadline, [&] {
      return std::all_of(shot_.reported.begin(), shot_.reported.end(), [&](std::uint64_t r) { return r == gen; });
    });
    for (std::size_t i = 0; i < members_.size(); ++i) {
      if (shot_.reported[i] != gen) {
        timed_out[i] = shot_.abandoned[i] = 1;
        in_flight[i] = shot_.taken[i];
      }
      const Nanos called = shot_.called[i];
      if (called == 0) continue;
      first = first == 0 ? called : std::min(first, called);
      if (shot_.accepted[i] == 0) continue;
      t.exposures[i] = called + latency_ns_;
      lo = accepted == 0 ? called : std::min(lo, called);
      hi = std::max(hi, called);
      ++accepted;
    }
    figures_lock.lock();
  }
  ++figures_.triggers;
  if (first != 0 && first - aim > kLateNs) ++figures_.late;
  for (std::size_t i = 0; i < members_.size(); ++i) {
    if (timed_out[i] != 0) ++members_[i].timed_out;
    // A call in flight for this shot is refused or recorded when it returns (settle_late_call); a
    // member still in an older shot's call never takes this one: refused now.
    if (in_flight[i] != 0) continue;
    if (t.exposures[i] == 0)
      ++members_[i].refused;
    else {
      members_[i].exposures.add(t.exposures[i]);
      members_[i].accepted_mono.add(monotonic_now_ns());
    }
  }
  if (accepted > 1) spread_.add(hi - lo);
  if (accepted > 0 || std::any_of(timed_out.begin(), timed_out.end(), [](char c) { return c != 0; })) ticks_.push_back(std::move(t));
  while (ticks_.size() > kKeepTicks) {  // the LIDAR's samples stopped coming: never measured
    if (!ticks_.front().settled) ++figures_.unmeasured;
    ticks_.pop_front();
  }
}

NextCrossing choose_next_crossing(const std::function<std::optional<Nanos>(Nanos)>& crossing_after, Nanos last_target,
                                  Nanos hittable, Nanos period) {
  if (last_target == 0 || period <= 0) return {crossing_after(hittable), 0};
  // The crossing after the one just fired (not that one twice), even when the trigger thread woke
  // after it: a loaded host, a sleep's overshoot, a partner's call held to its deadline. Fired late
  // it is a frame stamped by its own call (counted late); skipped, it was a frame lost by every
  // member with nothing counting it (chaos campaign seed 25: 17-43 stereo frames of ~450 in 45 s,
  // the trigger thread waking 0.4-12 ms after the crossing it had slept towards).
  const auto following = crossing_after(last_target + period / 2);
  if (!following || *following >= hittable - period / 4) return {following, 0};
  // More than a quarter turn past: the camera would see another sector than the LIDAR's crossing.
  // The next one that can be hit instead; the ones passed are counted.
  const auto hit = crossing_after(hittable);
  if (!hit) return {hit, 0};
  const auto turns = std::llround(static_cast<double>(*hit - last_target) / static_cast<double>(period));
  return {hit, turns > 1 ? static_cast<std::uint64_t>(turns - 1) : 0};
}

void LidarTrigger::run() {
  Nanos last_target = 0;  // the crossing fired last; 0: none since the prediction (re)appeared
  while (!stop_.load()) {
    const Nanos now = vehicle_now_ns();
    std::optional<Nanos> target;
    {
      std::lock_guard lock(mutex_);
      const Nanos period = phase_.period_ns();
      // A crossing sooner than the latency cannot be hit on time.
      const auto next = choose_next_crossing([&](Nanos after) { return phase_.next_crossing(cfg_.azimuth_deg, after, now); },
                                             last_target, now + latency_ns_, period);
      target = next.target;
      figures_.skipped += next.skipped;
      // Counted once: the passed crossings are behind the one aimed at now.
      if (next.skipped > 0) last_target = *target - period;
      if (!target && figures_.predicting) ++figures_.prediction_lost;
      figures_.predicting = target.has_value();
    }
    if (!target) {
      // No prediction: no trigger (counted, in status). The crossings of the outage are not
      // skipped ones: the next shot is the first crossing that can be hit.
      last_target = 0;
      sleep_until_vehicle(now + 10'000'000);
      continue;
    }
    const Nanos aim = *target - latency_ns_;
    if (aim - now > kApproachNs) {
      // Sleep towards it, then predict again: the newest scan may have moved it.
      sleep_until_vehicle(std::min(aim - kApproachNs, now + kMaxSleepNs));
      continue;
    }
    fire(*target, aim);  // an aim already passed fires at once (counted late)
    last_target = *target;
  }
}

Nanos LidarTrigger::first_accepted_since(std::size_t member, Nanos mono) const {
  std::lock_guard lock(mutex_);
  return member < members_.size() ? members_[member].accepted_mono.first_since(mono) : 0;
}

LidarTriggerFigures LidarTrigger::figures(std::size_t member) const {
  std::lock_guard lock(mutex_);
  LidarTriggerFigures f = figures_;
  f.sweep = phase_.status(vehicle_now_ns());
  f.members = members_.size();
  if (member < members_.size()) {
    const auto& m = members_[member];
    f.refused = m.refused;
    f.timed_out = m.timed_out;
    f.calls_left = m.calls_left;
    f.call_error = figure_of(m.call_error);
    f.to_exposure = figure_of(m.to_exposure);
    f.exposure_unmatched = m.unmatched;
    f.from_device = m.device_error.count() > 0;
    const ErrorFigure phase = f.from_device ? figure_of(m.device_error) : f.call_error;
    f.measured = phase.count;
    f.error_p50_ns = phase.p50_ns;
    f.error_p99_ns = phase.p99_ns;
    f.error_max_ns = phase.max_ns;
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
  s.add_number("triggers_timed_out", f.timed_out);
  s.add_number("trigger_calls_left", f.calls_left);
  s.add_number("triggers_late", f.late);
  s.add_number("triggers_skipped", f.skipped);
  s.add_number("trigger_prediction_lost", f.prediction_lost);
  // The phase figure's exposure start: the camera's own report, or the trigger call + latency.
  s.add("phase_from", f.from_device ? "device_exposure" : "trigger_call");
  s.add_number("phase_measured", f.measured);
  s.add_number("phase_unmeasured", f.unmeasured);
  s.add("phase_error_p50_ms", ms(f.error_p50_ns));
  s.add("phase_error_p99_ms", ms(f.error_p99_ns));
  s.add("phase_error_max_ms", ms(f.error_max_ns));
  add_figure(s, "trigger_call_error", f.call_error);
  if (f.to_exposure.count > 0) add_figure(s, "trigger_to_exposure", f.to_exposure);
  s.add_number("exposure_unmatched", f.exposure_unmatched);
  if (f.members > 1) {  // a group (stereo pair): one tick, every member's call at once
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
