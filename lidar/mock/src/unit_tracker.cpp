// Scans of a synthetic stream as the decoders cut them (see unit_tracker.hpp). The rules mirror
// velodyne/src/decoder.cpp (a group crossing the cut starts the next scan) and hesai/src/decoder.cpp
// (groups between the window's start and the cut belong to both scans); test_lidar_truth checks the
// result against those decoders.
#include "sensor_rig/lidar/mock/unit_tracker.hpp"

#include <algorithm>
#include <array>
#include <cstddef>

namespace sensor_rig::lidar::mock {
namespace {

constexpr int kAzimuthCount = 36000;

int az_step(int a, int b) noexcept {
  const int d = b - a;
  return d < 0 ? d + kAzimuthCount : d;
}
// `target` in (prev, prev + step] on a forward step shorter than half a turn (any forward step for
// the first group of a packet: the decoders judge that step by the gap since the previous packet).
bool crosses(int prev, int step, int target, bool any_length) noexcept {
  if (step <= 0 || (step >= kAzimuthCount / 2 && !any_length)) return false;
  const int to = az_step(prev, target);
  return to > 0 && to <= step;
}
bool in_sector(int start, int end, int a) noexcept {
  return start <= end ? (a >= start && a <= end) : (a >= start || a <= end);
}

}  // namespace

void UnitTracker::start(Open& u, Nanos acq, Nanos dev) noexcept {
  u = Open{next_unit_++, acq, dev, 0, true};
}

void UnitTracker::close_current() {
  if (have_cur_) closed_.push_back(ClosedUnit{cur_.unit, cur_.acq_ns, cur_.dev_ns, cur_.parts});
  have_cur_ = false;
}

void UnitTracker::restart() noexcept { force_new_ = true; }

void UnitTracker::finish() {
  close_current();
  if (next_.started) closed_.push_back(ClosedUnit{next_.unit, next_.acq_ns, next_.dev_ns, next_.parts});
  next_ = Open{};
  window_open_ = false;
}

UnitSpan UnitTracker::add(const PacketTruth& t, bool counted) {
  const auto dev_at = [&](Nanos acq) { return t.dev_ns + (acq - t.acq_ns); };
  if (force_new_) {  // a reboot: what was open ends as it is
    finish();
    have_prev_ = false;
    force_new_ = false;
  }
  UnitSpan span{-1, -1};
  const auto touch = [&](const Open& u) {
    if (span.first < 0 || u.unit < span.first) span.first = u.unit;
    span.last = std::max(span.last, u.unit);
  };
  std::array<ClosedUnit, PacketTruth::kMaxGroups> ended{};  // units a cut inside this packet ended
  std::size_t n_ended = 0;
  if (rule_.kind == UnitRule::Kind::kFrame) {
    if (!have_cur_ || !have_prev_ || t.frame != prev_frame_) {
      close_current();
      start(cur_, t.acq_ns, t.dev_ns);
      have_cur_ = true;
    }
    prev_frame_ = t.frame;
    have_prev_ = true;
    if (counted) ++cur_.parts;
    return {cur_.unit, cur_.unit};
  }
  for (std::size_t g = 0; g < t.groups; ++g) {
    const int a = t.group_az[g];
    const Nanos tg = t.group_ns[g];
    if (!have_cur_) {
      start(cur_, tg, dev_at(tg));
      have_cur_ = true;
    }
    if (rule_.kind == UnitRule::Kind::kAzimuthCut) {
      if (have_prev_ && crosses(prev_az_, az_step(prev_az_, a), rule_.emit_raw, g == 0)) {
        ended[n_ended++] = ClosedUnit{cur_.unit, cur_.acq_ns, cur_.dev_ns, cur_.parts};
        start(cur_, tg, dev_at(tg));
      }
      touch(cur_);
    } else {
      bool cut_here = false;
      if (have_prev_) {
        const int step = az_step(prev_az_, a);
        if (crosses(prev_az_, step, rule_.reset_raw, g == 0)) window_open_ = true;
        cut_here = crosses(prev_az_, step, rule_.emit_raw, g == 0);
      } else {
        window_open_ = in_sector(rule_.reset_raw, rule_.emit_raw, a) && a != rule_.emit_raw;
      }
      if (window_open_ || cut_here) {
        if (!next_.started) start(next_, tg, dev_at(tg));
        touch(next_);
      }
      touch(cur_);
      if (cut_here) {
        ended[n_ended++] = ClosedUnit{cur_.unit, cur_.acq_ns, cur_.dev_ns, cur_.parts};
        cur_ = next_;
        next_ = Open{};
        window_open_ = false;
      }
    }
    prev_az_ = a;
    have_prev_ = true;
  }
  // Count the packet in every unit it touched; a unit ended inside it counts it too.
  if (counted) {
    for (std::size_t i = 0; i < n_ended; ++i)
      if (ClosedUnit& e = ended[i]; e.unit >= span.first && e.unit <= span.last) ++e.parts;
    if (cur_.unit >= span.first && cur_.unit <= span.last) ++cur_.parts;
    if (next_.started && next_.unit >= span.first && next_.unit <= span.last) ++next_.parts;
  }
  closed_.insert(closed_.end(), ended.begin(), ended.begin() + static_cast<std::ptrdiff_t>(n_ended));
  return span;
}

}  // namespace sensor_rig::lidar::mock
