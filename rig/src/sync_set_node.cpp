#include "sync_set_node.hpp"

#include <atomic>
#include <map>
#include <mutex>
#include <thread>

#include "sensor_rig/common/latency_window.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/timesync/synchronizer.hpp"

namespace sensor_rig::rig {
namespace {

// Sets are small: reliable, keep-last 16 so a reader that polls slower than bursts loses none.
dds::QosSpec set_qos() {
  dds::QosSpec q;
  q.depth = 16;
  return q;
}

struct SetState {
  SyncSetConfig cfg;
  timesync::Synchronizer sync;
  dds::Topic<msg::SyncSet> topic;
  dds::Writer<msg::SyncSet> writer;
  std::uint64_t seq = 0;
  LatencyWindow spread_ms;  // since the last diagnostics
  std::uint64_t last_incomplete = 0;
  std::uint64_t write_errors = 0;
  Nanos last_report_ns = 0;
  std::uint64_t sets_at_last_report = 0;

  SetState(const SyncSetConfig& c, const dds::Participant& p)
      : cfg(c), sync(c.synchronizer_config()), topic(p, c.topic(), set_qos()), writer(p, topic, set_qos()) {}
};

}  // namespace

struct SyncSetNode::Impl {
  dds::Topic<msg::SourceStamps> stamps_topic;
  dds::Reader<msg::SourceStamps> stamps_reader;
  std::vector<std::unique_ptr<SetState>> sets;
  std::multimap<std::string, std::pair<std::size_t, std::uint32_t>> members;  // topic -> (set, member)
  std::mutex mutex;
  std::atomic<bool> running{false};
  std::thread thread;

  Impl(const std::vector<SyncSetConfig>& cfgs, const dds::Participant& p)
      : stamps_topic(p, dds::kStampsTopic, dds::stamps_qos()), stamps_reader(p, stamps_topic, dds::stamps_qos()) {
    for (const auto& c : cfgs) {
      sets.push_back(std::make_unique<SetState>(c, p));
      for (std::uint32_t m = 0; m < c.members.size(); ++m) members.emplace(c.members[m], std::make_pair(sets.size() - 1, m));
    }
  }

  void publish(SetState& s, const timesync::SyncSet& set) {
    std::vector<msg::SetMember> mem(set.samples.size());
    for (std::size_t i = 0; i < set.samples.size(); ++i) {
      mem[i].topic = const_cast<char*>(s.cfg.members[i].c_str());  // C type not const-correct; not written through
      mem[i].stamp = msg::to_time(set.samples[i].stamp_ns);
      mem[i].seq = set.samples[i].seq;
    }
    msg::SyncSet m{};
    m.header.stamp = msg::to_time(set.first_ns);
    m.header.frame_id = const_cast<char*>(s.cfg.name.c_str());
    m.set_seq = s.seq++;
    m.spread_ns = set.spread_ns;
    m.members._buffer = mem.data();
    m.members._length = static_cast<std::uint32_t>(mem.size());
    m.members._maximum = m.members._length;
    m.members._release = false;
    if (!s.writer.write(m, vehicle_now_ns()).ok()) ++s.write_errors;
    s.spread_ms.add(static_cast<double>(set.spread_ns) * 1e-6);
  }

  void loop() {
    timesync::SyncSet out;
    while (running.load(std::memory_order_relaxed)) {
      stamps_reader.wait(20);
      const Nanos now = monotonic_now_ns();  // arrival clock of the timeouts: immune to realtime steps
      std::lock_guard lock(mutex);
      stamps_reader.take(
          [&](const msg::SourceStamps& st, const dds_sample_info_t&) {
            if (st.topic == nullptr) return;
            const auto [lo, hi] = members.equal_range(st.topic);
            for (auto it = lo; it != hi; ++it)
              sets[it->second.first]->sync.push({it->second.second, msg::from_time(st.header.stamp), st.seq, now}, now);
          },
          1024);
      for (auto& s : sets) {
        s->sync.poll(now);
        while (s->sync.pop(out)) publish(*s, out);
      }
    }
  }
};

SyncSetNode::SyncSetNode(const std::vector<SyncSetConfig>& sets, const dds::Participant& participant)
    : impl_(std::make_unique<Impl>(sets, participant)) {}

SyncSetNode::~SyncSetNode() { stop(); }

void SyncSetNode::start() {
  if (impl_->sets.empty() || impl_->running.exchange(true)) return;
  impl_->thread = std::thread([this] { impl_->loop(); });
}

void SyncSetNode::stop() {
  impl_->running = false;
  if (impl_->thread.joinable()) impl_->thread.join();
}

void SyncSetNode::supervise(std::vector<dds::DriverStatus>& statuses) {
  std::lock_guard lock(impl_->mutex);
  const Nanos now = monotonic_now_ns();
  for (auto& sp : impl_->sets) {
    auto& s = *sp;
    const auto& st = s.sync.stats();
    dds::DriverStatus d;
    d.name = "rig/sets/" + s.cfg.name;
    d.hardware_id = s.cfg.topic();
    const double window_s = s.last_report_ns > 0 ? static_cast<double>(now - s.last_report_ns) * 1e-9 : 0.0;
    const double rate = window_s > 0 ? static_cast<double>(st.sets - s.sets_at_last_report) / window_s : 0.0;
    const auto p = s.spread_ms.take();
    d.add("policy", timesync::to_string(s.cfg.policy));
    d.add_number("members", s.cfg.members.size());
    d.add_number("rate_hz", rate);
    d.add_number("sets", st.sets);
    d.add_number("incomplete", st.incomplete);
    d.add_number("dropped", st.dropped);
    d.add_number("late", st.late);
    d.add_number("implausible", st.implausible);  // future stamps not followed by their member (issue 27 item 6)
    d.add_number("jumps", st.jumps);
    d.add_number("timeouts", st.timeouts);
    d.add_number("spread_p50_ms", p.p50);
    d.add_number("spread_p99_ms", p.p99);
    d.add_number("spread_max_ms", p.max);
    for (std::size_t m = 0; m < s.cfg.members.size(); ++m)
      if (st.dropped_per_member[m] > 0) d.add("dropped " + s.cfg.members[m], std::to_string(st.dropped_per_member[m]));
    if (st.sets == 0) {
      d.level = dds::Level::kWarn;
      d.message = "no complete set yet";
    } else if (st.incomplete > s.last_incomplete) {
      d.level = dds::Level::kWarn;
      d.message = std::to_string(st.incomplete - s.last_incomplete) + " incomplete sets since the last report";
    } else {
      d.message = "running";
    }
    s.last_incomplete = st.incomplete;
    s.sets_at_last_report = st.sets;
    s.last_report_ns = now;
    statuses.push_back(std::move(d));
  }
}

}  // namespace sensor_rig::rig
