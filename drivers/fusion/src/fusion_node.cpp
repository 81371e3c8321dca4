#include "sensor_rig/drivers/fusion/fusion_node.hpp"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <thread>

#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/realtime_thread.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/dds/publish_stats.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/drivers/fusion/scan_filter.hpp"
#include "sensor_rig/drivers/fusion/sweep_matcher.hpp"

#include "matcher_log.hpp"

namespace sensor_rig::drivers {
namespace {

// A scan as handed over by its LIDAR node: what the fused stamps need, and a copy of the points.
struct InputScan {
  std::uint32_t source = 0;
  Nanos stamp = 0;
  Nanos first_rx_ns = 0;
  Nanos written_ns = 0;  // the input on the wire
  Nanos arrival_ns = 0;  // handed to this node (monotonic: the matcher's deadlines must not step)
  std::uint64_t seq = 0;  // the scan's seq on /rig/stamps: its identity in the sweep's members
  std::uint32_t packets = 0, dropped = 0, missing_packets = 0;
  bool stamp_unsynchronized = false;  // its LIDAR's topic was flagged as it went out
  std::vector<lidar::PointXYZIRT> points;
};

// One source's part of an open sweep: filtered on arrival straight into the sweep's published
// buffer (the sweep's last scan is the only one filtered after the sweep is complete).
struct SweepPart {
  bool present = false;
  InputScan meta;  // points moved out (recycled)
  std::size_t begin = 0, end = 0;  // its points in the fused buffer
};

// An open sweep (the matcher's id; 0 = free): its parts and its points = the published buffer, reused.
struct SweepSlot {
  std::uint64_t id = 0;
  std::vector<SweepPart> parts;
  std::vector<FusedPoint> fused;
};

SweepMatcherConfig matcher_config(const FusionConfig& c, std::size_t sources) {
  return {static_cast<std::uint32_t>(sources), static_cast<Nanos>(c.max_spread_ms) * 1'000'000,
          static_cast<Nanos>(c.timeout_ms) * 1'000'000};
}

// The fused stamp is a member's and every point's time is re-based on it: a sweep with a member
// whose LIDAR flagged its stamps flags the fused topic's (`stamp_sync: unsynchronized`), for as
// long after as the LIDAR nodes hold their flag.
constexpr Nanos kUnsyncHoldNs = 2'000'000'000;

// Scans waiting for the node's thread beyond this many per LIDAR are dropped (oldest first).
constexpr std::size_t kMaxQueuedPerSource = 3;

// The members sets are small: reliable, keep-last 16 (as the synchronizer's), so that a reader
// polling slower than a burst of sweeps loses none.
dds::QosSpec members_qos() {
  dds::QosSpec q;
  q.depth = 16;
  return q;
}

}  // namespace

struct FusionNode::Impl {
  struct Input final : ScanObserver {
    Impl* node = nullptr;
    std::uint32_t source = 0;
    void observe_scan(const lidar::Scan& scan, Nanos written_ns, bool stamp_unsynchronized) override {
      node->enqueue(source, scan, written_ns, stamp_unsynchronized);
    }
  };

  FusionConfig cfg;
  std::vector<std::string> names;
  std::vector<std::string> lidar_topics;  // per source: its scans' topic, as the members name it
  std::vector<Input> inputs;
  std::vector<ScanFilter> filters;  // thread only
  SweepMatcher matcher;             // thread only
  MatcherLog matcher_log;           // thread only
  std::vector<SweepSlot> slots;     // thread only: one per open sweep, reused
  // Thread only, per source: packets a whole scan of it holds (its last scan's packets + missing),
  // what a sweep without it is missing; 0 until it delivered.
  std::vector<std::uint32_t> expected_packets;
  std::vector<msg::PointField> fields = msg::point_fields(kFusedPointFields);
  dds::Topic<msg::PointCloud2> topic;
  dds::Writer<msg::PointCloud2> writer;
  dds::Topic<msg::SyncSet> members_topic;
  dds::Writer<msg::SyncSet> members_writer;
  std::vector<msg::SetMember> members;  // thread only: the sweep being written, reused
  dds::StampsWriter& stamps;
  std::thread thread;

  mutable std::mutex mutex;  // guards everything below
  std::condition_variable wake;
  bool stop_flag = false;
  std::deque<InputScan> queue;
  std::vector<std::vector<lidar::PointXYZIRT>> spare;  // recycled point buffers: no page faults per scan
  std::uint64_t dropped_backlog = 0;
  std::uint64_t members_write_errors = 0;
  std::uint64_t seq = 0;
  dds::PublishStats published;
  SweepCounters sweep_counters;
  std::vector<ScanFilterCounters> filter_counters;
  std::size_t last_points = 0;
  std::size_t last_sources = 0;
  Nanos unsync_seen_mono_ns = 0;  // the last sweep with a flagged member (CLOCK_MONOTONIC; 0 = never)
  std::string unsync_member;      // its flagged LIDAR
  std::string last_error;

  Impl(const FusionConfig& c, const std::vector<LidarConfig>& lidars, const dds::Participant& p, dds::StampsWriter& s)
      : cfg(c), inputs(lidars.size()), matcher(matcher_config(c, lidars.size())), matcher_log(c.matcher_log), expected_packets(lidars.size(), 0),
        topic(p, kFusedTopic, c.qos), writer(p, topic, c.qos), members_topic(p, kFusedSetsTopic, members_qos()),
        members_writer(p, members_topic, members_qos()), stamps(s), filter_counters(lidars.size()) {
    for (std::size_t i = 0; i < lidars.size(); ++i) {
      const auto& l = lidars[i];
      if (!l.extrinsics) throw std::invalid_argument("fusion: lidar " + l.name + " has no extrinsics");
      names.push_back(l.name);
      lidar_topics.push_back("/sensors/lidar/" + l.name + "/points");
      inputs[i].node = this;
      inputs[i].source = static_cast<std::uint32_t>(i);
      filters.emplace_back(to_transform(*l.extrinsics), c.crop_box, c.voxel_leaf_m, static_cast<std::uint16_t>(i));
    }
  }

  void enqueue(std::uint32_t source, const lidar::Scan& scan, Nanos written_ns, bool stamp_unsynchronized) {
    InputScan in{source, scan.stamp, scan.first_rx_ns, written_ns, monotonic_now_ns(), scan.seq,
                 scan.packets, scan.dropped, scan.missing_packets, stamp_unsynchronized, {}};
    {
      std::lock_guard lock(mutex);
      if (!spare.empty()) {
        in.points = std::move(spare.back());
        spare.pop_back();
      }
    }
    in.points.assign(scan.points.begin(), scan.points.end());  // outside the lock: the other LIDARs' copies run too
    std::lock_guard lock(mutex);
    if (queue.size() >= kMaxQueuedPerSource * inputs.size()) {  // the thread is stuck: keep the newest
      spare.push_back(std::move(queue.front().points));
      queue.pop_front();
      ++dropped_backlog;
    }
    queue.push_back(std::move(in));
    wake.notify_one();
  }

  void recycle(std::vector<lidar::PointXYZIRT>&& points) {
    std::lock_guard lock(mutex);
    spare.push_back(std::move(points));
  }

  SweepSlot& slot_for(std::uint64_t id) {
    for (auto& s : slots)
      if (s.id == id) return s;
    for (auto& s : slots)
      if (s.id == 0) {
        s.id = id;
        return s;
      }
    auto& s = slots.emplace_back();
    s.id = id;
    s.parts.resize(inputs.size());
    return s;
  }

  void handle(InputScan& in) {
    // The scan's span (its latest point's time): a slower LIDAR's scan spans more than one rotation.
    std::uint32_t span = 0;
    for (const auto& pt : in.points) span = std::max(span, pt.t);
    const auto place = matcher.push(in.source, in.stamp, in.arrival_ns, static_cast<Nanos>(span), in.stamp_unsynchronized);
    matcher_log.scan(in.source, in.seq, in.stamp, in.arrival_ns, static_cast<Nanos>(span), in.stamp_unsynchronized,
                     place.late ? -1 : static_cast<std::int64_t>(place.sweep));
    expected_packets[in.source] = in.packets + in.missing_packets;
    if (!place.late) {
      auto& slot = slot_for(place.sweep);
      auto& part = slot.parts[in.source];
      part.begin = slot.fused.size();
      filters[in.source].apply(in.points, slot.fused);
      part.end = slot.fused.size();
      part.present = true;
      recycle(std::move(in.points));
      part.meta = std::move(in);
    } else {
      recycle(std::move(in.points));
    }
  }

  void emit_ready() {
    const Nanos now = monotonic_now_ns();
    while (auto closed = matcher.ready(now)) {
      matcher_log.sweep(now, closed->id, closed->complete);
      emit(*closed);
    }
  }

  // A closed sweep's parts as one cloud: stamp = the earliest scan's, each point's t re-based on it.
  // Its stamps count a missing LIDAR's whole scan as missing packets; its members set names the
  // scans it holds (the same parts, so the two cannot disagree).
  void emit(const ClosedSweep& closed) {
    SweepSlot& slot = slot_for(closed.id);
    Nanos stamp = INT64_MAX, first_rx = INT64_MAX, last_written = 0;
    std::size_t sources = 0;
    std::uint32_t packets = 0, dropped = 0, missing = 0;
    const std::string* flagged = nullptr;  // a member whose stamps its LIDAR flagged
    members.clear();
    for (std::size_t i = 0; i < slot.parts.size(); ++i) {
      const auto& p = slot.parts[i];
      if (!p.present) {
        // An absent LIDAR's whole scan is missing, unless its scan of an earlier sweep spans this one
        // (a slower LIDAR: covered, lacks nothing).
        if (i >= closed.covered.size() || !closed.covered[i]) missing += expected_packets[i];
        continue;
      }
      msg::SetMember m{};
      m.topic = const_cast<char*>(lidar_topics[i].c_str());  // C type not const-correct; not written through
      m.stamp = msg::to_time(p.meta.stamp);
      m.seq = p.meta.seq;
      members.push_back(m);
      stamp = std::min(stamp, p.meta.stamp);
      first_rx = std::min(first_rx, p.meta.first_rx_ns);
      last_written = std::max(last_written, p.meta.written_ns);
      packets += p.meta.packets;
      dropped += p.meta.dropped;
      missing += p.meta.missing_packets;
      if (p.meta.stamp_unsynchronized) flagged = &names[i];
      ++sources;
    }
    if (sources != 0) {
      for (auto& p : slot.parts) {
        if (!p.present) continue;
        const auto offset = static_cast<std::uint64_t>(p.meta.stamp - stamp);
        if (offset != 0)
          for (std::size_t k = p.begin; k < p.end; ++k)
            slot.fused[k].t = static_cast<std::uint32_t>(std::min<std::uint64_t>(slot.fused[k].t + offset, UINT32_MAX));
      }
      write(slot.fused, stamp, first_rx, last_written, packets, dropped, missing, sources);
      if (flagged != nullptr) {
        std::lock_guard lock(mutex);
        unsync_seen_mono_ns = monotonic_now_ns();
        unsync_member = *flagged;
      }
    }
    for (auto& p : slot.parts) p.present = false;
    slot.fused.clear();  // capacity kept: a later sweep fills it again
    slot.id = 0;
  }

  void write(const std::vector<FusedPoint>& fused, Nanos stamp, Nanos first_rx, Nanos last_input, std::uint32_t packets,
             std::uint32_t dropped, std::uint32_t missing, std::size_t sources) {
    const Nanos ready = vehicle_now_ns();
    msg::PointCloud2 pc{};
    pc.header.stamp = msg::to_time(stamp);
    pc.header.frame_id = const_cast<char*>(cfg.frame_id.c_str());
    pc.height = 1;
    pc.width = static_cast<std::uint32_t>(fused.size());
    pc.fields._buffer = fields.data();
    pc.fields._length = pc.fields._maximum = static_cast<std::uint32_t>(fields.size());
    pc.point_step = sizeof(FusedPoint);
    pc.row_step = pc.point_step * pc.width;
    pc.data._buffer = reinterpret_cast<std::uint8_t*>(const_cast<FusedPoint*>(fused.data()));
    pc.data._length = pc.data._maximum = pc.row_step;
    pc.is_dense = true;
    const Nanos publish = vehicle_now_ns();
    const auto rc = writer.write(pc, publish);
    const Nanos written = vehicle_now_ns();
    const std::uint64_t n = seq++;
    // "first/last packet" of the fused cloud: the inputs' first packet, the last input on the wire.
    const dds::SampleStamps st{stamp, first_rx, last_input, ready, publish, written, packets, dropped, pc.row_step, missing};
    stamps.write(kFusedTopic, pc.header.stamp, pc.header.frame_id, n, st);
    const bool members_written = write_members(stamp, n);
    std::lock_guard lock(mutex);
    if (!members_written) ++members_write_errors;
    if (!published.count(rc, publish)) last_error = "dds write: " + rc.message();
    last_points = fused.size();
    last_sources = sources;
  }

  // After the cloud and its stamps: the cloud's latency does not pay for it. set_seq = the cloud's seq.
  bool write_members(Nanos stamp, std::uint64_t seq_of_cloud) {
    Nanos latest = stamp;
    for (const auto& m : members) latest = std::max(latest, msg::from_time(m.stamp));
    msg::SyncSet set{};
    set.header.stamp = msg::to_time(stamp);
    set.header.frame_id = const_cast<char*>(kFusedSetName);
    set.set_seq = seq_of_cloud;
    set.spread_ns = latest - stamp;
    set.members._buffer = members.data();
    set.members._length = set.members._maximum = static_cast<std::uint32_t>(members.size());
    set.members._release = false;
    return members_writer.write(set, vehicle_now_ns()).ok();
  }

  void publish_counters() {
    std::lock_guard lock(mutex);
    sweep_counters = matcher.counters();
    for (std::size_t i = 0; i < filters.size(); ++i) filter_counters[i] = filters[i].counters();
  }

  void run() {
    std::deque<InputScan> batch;
    for (;;) {
      {
        std::unique_lock lock(mutex);
        const Nanos deadline = matcher.deadline();
        const auto wait = std::chrono::nanoseconds(deadline < 0 ? 50'000'000 : std::max<Nanos>(0, deadline - monotonic_now_ns()));
        wake.wait_for(lock, wait, [this] { return stop_flag || !queue.empty(); });
        if (stop_flag || shutdown_requested()) return;
        batch.swap(queue);
      }
      for (auto& in : batch) {
        handle(in);
        emit_ready();  // before the next scan: a sweep goes out as soon as it is whole
      }
      batch.clear();
      emit_ready();  // deadlines
      publish_counters();
    }
  }
};

FusionNode::FusionNode(const FusionConfig& cfg, const std::vector<LidarConfig>& lidars, const dds::Participant& participant,
                       dds::StampsWriter& stamps)
    : impl_(std::make_unique<Impl>(cfg, lidars, participant, stamps)) {}

FusionNode::~FusionNode() { stop(); }

ScanObserver* FusionNode::input(std::size_t index) { return index < impl_->inputs.size() ? &impl_->inputs[index] : nullptr; }

void FusionNode::start() {
  impl_->thread = std::thread([this] { impl_->run(); });
  make_realtime(impl_->thread, impl_->cfg.realtime_priority, "fusion");
  std::string from;
  for (const auto& n : impl_->names) from += (from.empty() ? "" : ", ") + n;
  log::info("fusion", "lidars " + from + " -> " + kFusedTopic + " in " + impl_->cfg.frame_id);
}

void FusionNode::stop() {
  {
    std::lock_guard lock(impl_->mutex);
    impl_->stop_flag = true;
  }
  impl_->wake.notify_one();
  if (!impl_->thread.joinable()) return;
  impl_->thread.join();
  const auto& c = impl_->sweep_counters;
  log::info("fusion", "sweeps=" + std::to_string(c.sweeps) + " complete=" + std::to_string(c.complete) +
                          " partial_timeout=" + std::to_string(c.partial_timeout) +
                          " partial_dead=" + std::to_string(c.partial_dead) +
                          " partial_next_sweep=" + std::to_string(c.partial_next_sweep) +
                          " late_scans=" + std::to_string(c.late_scans) + " repeated_scans=" + std::to_string(c.repeated_scans) +
                          " clock_steps_back=" + std::to_string(c.clock_steps_back));
}

dds::DriverStatus FusionNode::status() const {
  const auto& m = *impl_;
  std::lock_guard lock(m.mutex);
  dds::DriverStatus s;
  s.name = "fusion";
  s.hardware_id = m.cfg.frame_id;
  const auto& c = m.sweep_counters;
  const Nanos age = m.published.last_ns() == 0 ? -1 : vehicle_now_ns() - m.published.last_ns();
  const bool unsynchronized = m.unsync_seen_mono_ns != 0 && monotonic_now_ns() - m.unsync_seen_mono_ns < kUnsyncHoldNs;
  if (m.published.samples() == 0) {
    s.level = dds::Level::kWarn;
    s.message = "waiting for scans";
  } else if (age > 1'000'000'000) {
    s.level = dds::Level::kError;
    s.message = "no sweep for " + std::to_string(age / 1'000'000) + " ms";
  } else if (!m.last_error.empty()) {
    s.level = dds::Level::kWarn;
    s.message = m.last_error;
  } else if (unsynchronized) {
    s.level = dds::Level::kWarn;
    s.message = "unsynchronized: a sweep holds a scan of " + m.unsync_member + " whose stamps its node flagged";
  } else if (m.last_sources < m.names.size()) {
    s.level = dds::Level::kWarn;
    s.message = "last sweep partial: " + std::to_string(m.last_sources) + " of " + std::to_string(m.names.size()) + " lidars";
  } else {
    s.message = "running";
  }
  s.add("topic", kFusedTopic);
  s.add("frame_id", m.cfg.frame_id);
  s.add("stamp_sync", unsynchronized ? "unsynchronized" : "ok");
  s.add_number("sweeps", m.published.samples());
  s.add("sweep_rate_hz", std::to_string(m.published.rate_hz()));
  s.add_number("complete_sweeps", c.complete);
  s.add_number("partial_timeout", c.partial_timeout);
  s.add_number("partial_dead", c.partial_dead);
  s.add_number("partial_next_sweep", c.partial_next_sweep);
  s.add_number("late_scans", c.late_scans);
  s.add_number("repeated_scans", c.repeated_scans);
  s.add_number("clock_steps_back", c.clock_steps_back);
  s.add_number("covered_by_slower", c.covered);
  s.add_number("head_lost_scans", c.head_lost_scans);
  s.add_number("unsynchronized_scans", c.unsynchronized_scans);
  s.add_number("resynchronized", c.resynchronized);
  s.add_number("dropped_backlog", m.dropped_backlog);
  s.add_number("points_last_sweep", m.last_points);
  s.add_number("lidars_last_sweep", m.last_sources);
  std::uint64_t cropped = 0, voxel_removed = 0, overflow = 0;
  for (const auto& f : m.filter_counters) {
    cropped += f.cropped;
    voxel_removed += f.voxel_removed;
    overflow += f.voxel_overflow;
  }
  s.add_number("points_cropped", cropped);
  s.add_number("points_voxel_merged", voxel_removed);
  s.add_number("voxel_overflow", overflow);
  for (std::size_t i = 0; i < m.names.size(); ++i) {
    s.add("source_" + std::to_string(i), m.names[i]);
    if (i < c.missing.size()) s.add_number("missing_" + m.names[i], c.missing[i]);
  }
  s.add_number("write_errors", m.published.write_errors());
  s.add("members_topic", kFusedSetsTopic);
  s.add_number("members_write_errors", m.members_write_errors);
  // Scans handed over and fused into no sweep: what `rig chaos` accounts a published scan by.
  s.add_number("scans_dropped", c.late_scans + c.repeated_scans + m.dropped_backlog);
  return s;
}

}  // namespace sensor_rig::drivers
