#include "monitor_stats.hpp"

#include <cstdio>
#include <cstdlib>

#include <algorithm>

namespace sensor_rig::rig {

void NodeTotal::on(std::uint64_t cumulative) {
  if (!seen) {
    seen = true;
    first = last = cumulative;
    return;
  }
  if (cumulative < last) {  // the node restarted: its count starts again from 0
    before_restart = total();
    first = 0;
  }
  last = cumulative;
}

void TopicStats::on_data(Nanos stamp, std::size_t size, const Arrival& a) {
  if (!data_seen) first_data(a.publish_ns);
  ++received;
  ++received_window;
  last_size = size;
  add(kDds, static_cast<double>(a.receive_ns - a.publish_ns) * 1e-6);
  if (auto it = unmatched_stamps.find(stamp); it != unmatched_stamps.end()) {
    SampleRecord r = std::move(it->second);
    unmatched_stamps.erase(it);  // before joined(): it is no longer undecided
    joined(std::move(r), a);
  } else if (auto lost_it = declared_lost.find(stamp); lost_it != declared_lost.end()) {
    declared_lost.erase(lost_it);  // slower than the loss timeout, yet delivered
    --lost;
    ++late;
  } else {
    unmatched_data.emplace(stamp, a);
  }
}

void TopicStats::on_stamps(const msg::SourceStamps& s, Nanos now) {
  has_stamps = true;
  if (!counting.admits(s.publish_ns)) return;
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
  r.packets = s.packets;
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

// The first sample this reader got: what was written before it was written before the writer
// matched this reader (start-up), whether still waiting or already declared lost.
void TopicStats::first_data(Nanos publish_ns) {
  data_seen = true;
  for (auto it = unmatched_stamps.begin(); it != unmatched_stamps.end();) {
    if (it->second.publish_ns >= publish_ns) {
      ++it;
      continue;
    }
    ++before_match;
    it = unmatched_stamps.erase(it);
  }
  std::erase_if(declared_lost, [&](const auto& kv) {
    if (kv.second.publish_ns >= publish_ns) return false;
    --lost;
    ++before_match;
    return true;
  });
  release(false);  // rows held behind the removed ones
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
      declared_lost.emplace(it->first, Declared{now, it->second.publish_ns});
      SampleRecord r = std::move(it->second);
      r.received_ns = 0;
      it = unmatched_stamps.erase(it);
      decided(std::move(r));
    } else {
      ++it;
    }
  }
  for (auto it = unmatched_data.begin(); it != unmatched_data.end();) {
    if (now - it->second.receive_ns <= loss_timeout_ns) {
      ++it;
      continue;
    }
    if (has_stamps && counting.admits(it->second.publish_ns)) ++unstamped;  // its stamps were lost
    it = unmatched_data.erase(it);
  }
  // A sample later than 5 loss timeouts is not coming: forget it (bounded memory).
  std::erase_if(declared_lost, [&](const auto& kv) { return now - kv.second.at > 5 * loss_timeout_ns; });
}

void CameraDrops::on_status(const std::map<std::string, std::string, std::less<>>& values) {
  for (std::size_t i = 0; i < kKeys.size(); ++i) {
    const auto it = values.find(kKeys[i]);
    if (it != values.end()) last[i] = std::strtoull(it->second.c_str(), nullptr, 10);
  }
  if (!seen) first = last;
  seen = true;
}

std::vector<std::pair<std::string_view, std::uint64_t>> drops_by_stage(const TopicStats& st) {
  static constexpr std::array<std::string_view, CameraDrops::kKeys.size()> kCameraStages = {
      "aravis_underrun", "aravis_timeout", "aravis_missing_packets", "aravis_other", "worker_queue", "dds_write"};
  std::vector<std::pair<std::string_view, std::uint64_t>> out;
  std::uint64_t explained = 0;
  if (st.camera.seen) {
    for (std::size_t i = 0; i < kCameraStages.size(); ++i) out.emplace_back(kCameraStages[i], st.camera.since_start(i));
    explained += st.camera.write_errors();  // its stamps were published: the monitor counts it lost
  }
  explained += st.reader_lost;
  out.emplace_back("reader_lost", st.reader_lost);
  out.emplace_back("lost_in_dds", st.lost > explained ? st.lost - explained : 0);
  out.emplace_back("late", st.late);
  out.emplace_back("before_match", st.before_match);
  out.emplace_back("unstamped", st.unstamped);
  return out;
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
  if (key == "phase_from") {
    phase_from = v;
    return true;
  }
  const auto part = [&](std::string_view prefix, Part& out) {
    const auto rest = key.substr(prefix.size());
    double* field = rest == "_p50_ms" ? &out.p50_ms : rest == "_p99_ms" ? &out.p99_ms : rest == "_max_ms" ? &out.max_ms : nullptr;
    if (field == nullptr || !number(*field)) return false;
    out.seen = true;
    return true;
  };
  if (key.starts_with("trigger_call_error_")) return part("trigger_call_error", call_error);
  if (key.starts_with("trigger_to_exposure_")) return part("trigger_to_exposure", to_exposure);
  if (key == "exposure_unmatched") return count(exposure_unmatched);
  if (key == "triggers") return count(triggers);
  if (key == "phase_measured") return count(measured);
  if (key == "phase_unmeasured") return count(unmeasured);
  if (key == "phase_error_p50_ms") return number(p50_ms);
  if (key == "phase_error_p99_ms") return number(p99_ms);
  if (key == "phase_error_max_ms") return number(max_ms);
  return false;
}

namespace {

// "p50/p99" of a part, "-" where the node did not publish it.
std::string p50_p99(const TriggerStats::Part& p) {
  if (!p.seen) return "-";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3f/%.3f", p.p50_ms, p.p99_ms);
  return buf;
}

// The table's short name for phase_from; an unknown value is shown as it came.
std::string_view phase_from_short(std::string_view from) {
  if (from == "device_exposure") return "device";
  if (from == "trigger_call") return "call";
  return from.empty() ? "-" : from;
}

nlohmann::json part_json(const TriggerStats::Part& p) {
  return nlohmann::json{{"p50", p.p50_ms}, {"p99", p.p99_ms}, {"max", p.max_ms}};
}

}  // namespace

std::string trigger_table_header() {
  char buf[256];
  std::snprintf(buf, sizeof buf, "%-24s %-8s %-10s %8s %6s %-6s | %-17s %-11s %-11s %7s\n", "triggered camera (ms)",
                "lidar", "sweep", "triggers", "unmeas", "from", "phase p50/p99/max", "host p50/99", "cam p50/99",
                "unmatch");
  return buf;
}

std::string trigger_table_row(const std::string& status_name, const TriggerStats& t) {
  char phase[96];
  std::snprintf(phase, sizeof phase, "%.3f/%.3f/%.3f", t.p50_ms, t.p99_ms, t.max_ms);
  const std::string from(phase_from_short(t.phase_from));
  char buf[512];
  std::snprintf(buf, sizeof buf, "%-24s %-8s %-10s %8llu %6llu %-6s | %-17s %-11s %-11s %7llu\n", status_name.c_str(),
                t.lidar.c_str(), t.sweep.c_str(), static_cast<unsigned long long>(t.triggers),
                static_cast<unsigned long long>(t.unmeasured), from.c_str(), phase, p50_p99(t.call_error).c_str(),
                p50_p99(t.to_exposure).c_str(), static_cast<unsigned long long>(t.exposure_unmatched));
  return buf;
}

nlohmann::json trigger_json(const std::string& status_name, const TriggerStats& t) {
  nlohmann::json j{{"trigger", status_name},
                   {"lidar", t.lidar},
                   {"sweep", t.sweep},
                   {"triggers", t.triggers},
                   {"measured", t.measured},
                   {"unmeasured", t.unmeasured},
                   {"phase_from", t.phase_from},
                   {"phase_error_ms", {{"p50", t.p50_ms}, {"p99", t.p99_ms}, {"max", t.max_ms}}},
                   {"exposure_unmatched", t.exposure_unmatched}};
  if (t.call_error.seen) j["trigger_call_error_ms"] = part_json(t.call_error);
  if (t.to_exposure.seen) j["trigger_to_exposure_ms"] = part_json(t.to_exposure);
  return j;
}

}  // namespace sensor_rig::rig
