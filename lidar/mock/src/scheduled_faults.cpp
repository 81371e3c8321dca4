// Scheduled network faults of the vocabulary (see scheduled_faults.hpp).
#include "sensor_rig/lidar/mock/scheduled_faults.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace sensor_rig::lidar::mock {

namespace {
constexpr std::uint64_t kJitterStream = 0x6a09e667f3bcc909ULL;  // the jitter's generator apart from rng_'s
}  // namespace

ScheduledFaults::ScheduledFaults(std::vector<NetFault> faults, std::uint64_t seed)
    : faults_(std::move(faults)), done_(faults_.size(), false), rng_(seed), jitter_rng_(seed ^ kJitterStream),
      walks_(faults_.size()) {}

void ScheduledFaults::decide(std::int64_t tag, truth::Fate fate, std::uint64_t fault) {
  if (tag >= 0) decisions_.push_back(NetDecision{tag, fate, fault});
}

std::span<std::byte> ScheduledFaults::keep(std::span<const std::byte> bytes) {
  if (store_used_ == store_.size()) store_.emplace_back();
  auto& b = store_[store_used_++];
  b.assign(bytes.begin(), bytes.end());
  return b;
}

void ScheduledFaults::release(Nanos offset, bool force) {
  for (auto it = held_.begin(); it != held_.end();) {
    const bool due = force || (it->release_ns >= 0 ? offset >= it->release_ns : it->after <= 0);
    if (!due) {
      ++it;
      continue;
    }
    out_.push_back(NetPacket{offset, keep(it->bytes), it->position, it->tag});
    it = held_.erase(it);
  }
}

std::span<const NetPacket> ScheduledFaults::push(const NetPacket& in, double rotor_deg) {
  out_.clear();
  store_used_ = 0;
  NetPacket p = in;
  for (std::size_t i = 0; i < faults_.size(); ++i) {  // a delayed network holds every packet back, in order
    const NetFault& f = faults_[i];
    if (f.kind == NetFault::Kind::kDelay && in.offset_ns >= f.from_ns && in.offset_ns < f.until_ns) {
      p.offset_ns += walks_[i].next(in.offset_ns, faults_[i].delay_ns, faults_[i].jitter_ns, jitter_rng_);
      if (!in.position) decide(in.tag, truth::Fate::kSent, f.id);
    }
  }
  // A held packet is never due before one held earlier: after the fault (or a hold that fell) they
  // queue behind it, as a network's FIFO drains.
  p.offset_ns = std::max(p.offset_ns, held_until_);
  if (p.offset_ns > in.offset_ns) held_until_ = p.offset_ns;
  if (p.position) {
    out_.push_back(p);
    return out_;
  }
  const double step = last_rotor_ >= 0 && rotor_deg >= 0 ? std::fmod(rotor_deg - last_rotor_ + 360.0, 360.0) : 0.0;
  last_rotor_ = rotor_deg;
  bool sent = true;
  const std::size_t held_before = held_.size();  // only these count this packet as passing them
  if (burst_ != nullptr) {
    decide(p.tag, truth::Fate::kDropped, burst_->id);
    sent = false;
    if (--burst_left_ <= 0) burst_ = nullptr;
  } else {
    for (std::size_t i = 0; i < faults_.size(); ++i) {
      const NetFault& f = faults_[i];
      if (done_[i] || f.kind == NetFault::Kind::kDelay || in.offset_ns < f.from_ns) continue;
      if (f.kind == NetFault::Kind::kLossBurst && f.at_cut && rotor_deg >= 0) {
        // Start so that half the burst falls before the cut: within packets/2 steps of 360°.
        const double before = std::floor(f.packets / 2.0);
        if (step <= 0 || step > 90.0 || rotor_deg + (before + 0.5) * step < 360.0) continue;
      }
      done_[i] = true;
      switch (f.kind) {
        case NetFault::Kind::kReorder:
          held_.push_back(Held{{p.bytes.begin(), p.bytes.end()}, false, p.tag, f.hold_ns > 0 ? 0 : std::max(1, f.n),
                               f.hold_ns > 0 ? p.offset_ns + f.hold_ns : -1});
          decide(p.tag, truth::Fate::kDelayed, f.id);
          sent = false;
          break;
        case NetFault::Kind::kDuplicateLate:
          held_.push_back(Held{{p.bytes.begin(), p.bytes.end()}, false, -1, std::max(1, f.n), -1});
          decide(p.tag, truth::Fate::kDuplicated, f.id);
          break;
        case NetFault::Kind::kLossBurst:
          decide(p.tag, truth::Fate::kDropped, f.id);
          sent = false;
          if (f.packets > 1) {
            burst_ = &f;
            burst_left_ = f.packets - 1;
          }
          break;
        case NetFault::Kind::kCorrupt: {
          const std::span<std::byte> bytes = keep(p.bytes);
          std::byte* b = bytes.data();
          FieldBytes fb = f.field;
          if (f.random_byte) fb = FieldBytes{static_cast<std::size_t>(rng_() % bytes.size()), 1};
          for (std::size_t k = fb.offset; k < fb.offset + fb.size && k < bytes.size(); ++k) b[k] ^= std::byte{0xA5};
          p.bytes = bytes;
          decide(p.tag, truth::Fate::kCorrupted, f.id);
          break;
        }
        case NetFault::Kind::kDelay: break;
      }
      break;  // one fault per packet
    }
  }
  if (sent) out_.push_back(p);
  for (std::size_t i = 0; i < held_before; ++i)
    if (held_[i].release_ns < 0) --held_[i].after;
  release(p.offset_ns, false);
  return out_;
}

std::span<const NetPacket> ScheduledFaults::flush() {
  out_.clear();
  store_used_ = 0;
  release(0, true);
  return out_;
}

}  // namespace sensor_rig::lidar::mock
