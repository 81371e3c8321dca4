#include "monitor_stats.hpp"

#include <cstdlib>

#include <algorithm>

namespace sensor_rig::rig {

void TopicStats::on_data(Nanos stamp, std::size_t size, const Arrival& a) {
  ++received;
  ++received_window;
  last_size = size;
  add(kDds, static_cast<double>(a.receive_ns - a.publish_ns) * 1e-6);
  if (auto it = unmatched_stamps.find(stamp); it != unmatched_stamps.end()) {
    SampleRecord r = std::move(it->second);
    unmatched_stamps.erase(it);  // before joined(): it is no longer undecided
    joined(std::move(r), a);
  } else {
    unmatched_data.emplace(stamp, a);
  }
}

void TopicStats::on_stamps(const msg::SourceStamps& s, Nanos now) {
  has_stamps = true;
  if (s.publish_ns < counting_since) return;
  source_drops += s.dropped;
  missing_packets += s.missing_packets;
  SampleRecord r;
  r.topic = name;
  r.seq = s.seq;
  r.acquisition_ns = s.acquisition_ns;
  r.first_rx_ns = s.first_rx_ns;
  r.last_rx_ns = s.last_rx_ns;
  r.publish_ns = s.publish_ns;
  r.written_ns = s.written_ns;
  r.missing_packets = s.missing_packets;
  r.dropped = s.dropped;
  r.size_bytes = s.size_bytes;
  r.ecu_status_ns = s.ecu_status_ns;
  const Nanos stamp = msg::from_time(s.header.stamp);
  if (auto it = unmatched_data.find(stamp); it != unmatched_data.end()) {
    joined(std::move(r), it->second);
    unmatched_data.erase(it);
  } else {
    r.received_ns = now;  // "seen at", for the loss timeout
    unmatched_stamps.insert_or_assign(stamp, std::move(r));
  }
}

void TopicStats::joined(SampleRecord r, const Arrival& a) {
  r.received_ns = a.receive_ns;
  const auto latencies = stage_latencies_ms(r);
  for (std::size_t i = 0; i < kStageCount; ++i)
    if (i != kDds && latencies[i]) add(i, *latencies[i]);  // dds: per data sample, in on_data
  decided(std::move(r));
}

void TopicStats::decided(SampleRecord r) {
  if (!on_record) return;
  const std::uint64_t seq = r.seq;
  decided_by_seq.insert_or_assign(seq, std::move(r));
  release(false);
}

void TopicStats::release(bool all) {
  std::uint64_t first_open = std::numeric_limits<std::uint64_t>::max();
  if (!all)
    for (const auto& [stamp, r] : unmatched_stamps) first_open = std::min(first_open, r.seq);
  while (!decided_by_seq.empty() && decided_by_seq.begin()->first < first_open) {
    on_record(decided_by_seq.begin()->second);
    decided_by_seq.erase(decided_by_seq.begin());
  }
}

void TopicStats::release_all() {
  if (on_record) release(true);
}

void TopicStats::add(std::size_t stage, double value) {
  stages[stage].add(value);
  run_stages[stage].add(value);
}

void TopicStats::expire(Nanos now, Nanos loss_timeout_ns) {
  for (auto it = unmatched_stamps.begin(); it != unmatched_stamps.end();) {
    if (now - it->second.received_ns > loss_timeout_ns) {
      ++lost;
      SampleRecord r = std::move(it->second);
      r.received_ns = 0;
      it = unmatched_stamps.erase(it);
      decided(std::move(r));
    } else {
      ++it;
    }
  }
  for (auto it = unmatched_data.begin(); it != unmatched_data.end();)
    it = now - it->second.receive_ns > loss_timeout_ns ? unmatched_data.erase(it) : std::next(it);
}

void SetStats::on_set(const msg::SyncSet& m) {
  if (any && m.set_seq > next_seq) lost += m.set_seq - next_seq;  // published, not received
  any = true;
  next_seq = m.set_seq + 1;
  ++received;
  ++received_window;
  members = m.members._length;
  const double ms = static_cast<double>(m.spread_ns) * 1e-6;
  spread.add(ms);
  run_spread.add(ms);
}

bool TriggerStats::on_value(std::string_view key, std::string_view value) {
  const std::string v(value);
  char* end = nullptr;
  const auto number = [&](double& out) {
    const double d = std::strtod(v.c_str(), &end);
    if (end == v.c_str()) return false;
    out = d;
    return true;
  };
  const auto count = [&](std::uint64_t& out) {
    const auto n = std::strtoull(v.c_str(), &end, 10);
    if (end == v.c_str()) return false;
    out = n;
    return true;
  };
  if (key == "trigger_lidar") {
    lidar = v;
    return true;
  }
  if (key == "trigger_sweep") {
    sweep = v;
    return true;
  }
  if (key == "triggers") return count(triggers);
  if (key == "phase_measured") return count(measured);
  if (key == "phase_unmeasured") return count(unmeasured);
  if (key == "phase_error_p50_ms") return number(p50_ms);
  if (key == "phase_error_p99_ms") return number(p99_ms);
  if (key == "phase_error_max_ms") return number(max_ms);
  return false;
}

}  // namespace sensor_rig::rig
