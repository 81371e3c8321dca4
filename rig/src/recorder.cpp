#include "recorder.hpp"

#include "counting_gate.hpp"

#include <atomic>
#include <cinttypes>
#include <cstdio>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "qos_profiles.hpp"
#include "record_gaps.hpp"
#include "record_queue.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/common/thread_priority.hpp"
#include "sensor_rig/dds/discovery.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"
#include "sensor_rig/dds/topic.hpp"
#include "sensor_rig/dds/waitset.hpp"
#include "sensor_rig/record/split_writer.hpp"

namespace sensor_rig::rig {

struct RecordTopic {
  std::string ros_name;
  record::ChannelSpec spec;
  std::unique_ptr<dds::RawReader> reader;
  bool reliable = true;
  // DDS thread:
  std::uint64_t received = 0, received_bytes = 0, queue_dropped = 0;
  // Of those received, how many came in an iceoryx chunk (recorded from the chunk itself): the
  // summary's proof that --transport shm took the shared-memory path, not the network.
  std::uint64_t from_shared_memory = 0;
  // Announced on /rig/stamps from counting.since on (vehicle ns) and never received: what DDS lost
  // without saying (record_gaps.hpp's AnnouncedSamples counts it: missed, unannounced, overflow).
  CountingGate counting;
  // Writer thread (read by the DDS thread for progress):
  std::atomic<std::uint64_t> written{0}, disk_dropped{0}, queued{0};
  std::size_t channel = 0;  // writer thread only
  bool has_channel = false;
};

namespace {

struct WriterShared {
  std::atomic<bool> failed{false};
  std::mutex mu;
  std::string error;
  std::atomic<std::uint64_t> file_bytes{0}, files{0}, compress_ns{0}, write_ns{0}, chunks{0}, metadata_ns{0};
  std::vector<std::string> file_names;  // under mu
};

void writer_loop(record::SplitWriter& out, RecordQueue& q, WriterShared& w) {
  RecordItem item;
  const auto publish = [&] {
    const auto t = out.totals();
    w.file_bytes = t.file_bytes;
    w.compress_ns = static_cast<std::uint64_t>(t.compress_ns);
    w.write_ns = static_cast<std::uint64_t>(t.write_ns);
    w.chunks = t.chunks;
    w.files = out.files().size();
    w.metadata_ns = static_cast<std::uint64_t>(out.metadata_ns());
  };
  const auto fail = [&](const std::string& why) {
    std::lock_guard lock(w.mu);
    if (w.error.empty()) w.error = why;
    w.failed = true;
  };
  while (!q.closed_and_empty()) {
    if (!q.pop(item, std::chrono::milliseconds(100))) continue;
    RecordTopic& t = *item.topic;
    --t.queued;
    if (w.failed) {
      ++t.disk_dropped;
      item.sample.reset();
      continue;
    }
    try {
      if (!t.has_channel) {
        t.channel = out.add_channel(t.spec);
        t.has_channel = true;
      }
      const std::span<const std::byte> pieces[] = {item.sample.first(), item.sample.second()};
      const Nanos pub = item.sample.source_ts() > 0 ? item.sample.source_ts() : item.sample.receive_ts();
      out.write(t.channel, static_cast<std::uint64_t>(item.sample.receive_ts()), static_cast<std::uint64_t>(pub), pieces);
      ++t.written;
    } catch (const record::McapError& e) {
      ++t.disk_dropped;
      fail(e.what());
    }
    item.sample.reset();  // back to Cyclone (over shm: the chunk to the publisher's pool)
    publish();
  }
  if (!w.failed) {
    try {
      out.close();
    } catch (const record::McapError& e) {
      fail(e.what());
    }
  }
  publish();
  std::lock_guard lock(w.mu);
  w.file_names = out.files();
}

class Recorder {
 public:
  explicit Recorder(const RecordOptions& o)
      : opt_(o), participant_(o.dds), discovery_(participant_), waitset_(participant_),
        queue_(o.queue_mb << 20), wanted_(o.topics.begin(), o.topics.end()) {
    waitset_.attach_reader(discovery_.handle(), -1);
  }

  int run(record::SplitWriter& out) {
    std::thread writer([&] { writer_loop(out, queue_, shared_); });
    if (opt_.rt_priority > 0) {
      // On a host the rig saturates, normal threads get what SCHED_FIFO ones leave: the recorder
      // then falls behind and drops (counted). Both threads at the asked priority.
      for (const auto& r : {try_realtime_priority(opt_.rt_priority), try_realtime_priority(writer.native_handle(), opt_.rt_priority)})
        if (!r) std::fprintf(stderr, "rig record: SCHED_FIFO %d refused (%s): normal scheduling\n", opt_.rt_priority, r.why_not.c_str());
    }
    const Nanos start = monotonic_now_ns();
    const Nanos end = opt_.duration_s > 0 ? start + static_cast<Nanos>(opt_.duration_s * 1e9) : INT64_MAX;
    Nanos next_progress = start + 1'000'000'000;
    Nanos next_expire = start + kExpirePeriodNs;
    std::vector<std::int64_t> tags;
    while (!shutdown_requested() && !shared_.failed && monotonic_now_ns() < end) {
      waitset_.wait(tags, 50'000'000);
      for (const auto tag : tags) {
        if (tag < 0) discover();
        else take(topics_[static_cast<std::size_t>(tag)]);
      }
      if (const Nanos now = monotonic_now_ns(); now >= next_expire) {
        expire(now, kAnnouncedTimeoutNs);
        next_expire = now + kExpirePeriodNs;
      }
      if (const Nanos now = monotonic_now_ns(); now >= next_progress) {
        if (opt_.progress) progress(now - start);
        next_progress += 1'000'000'000;
      }
    }
    for (auto& t : topics_) take(t);  // what arrived before the stop
    // Announced a while before the stop and still not here: missed (the newest may be on the way).
    // Every seq gap seen is decided now: what it lacks is not in the file.
    announced_.expire(monotonic_now_ns(), kAnnouncedAtStopNs, 0);
    queue_.close();
    writer.join();
    for (auto& t : topics_) t.reader->update_status();
    if (opt_.progress) progress(monotonic_now_ns() - start);
    summary(monotonic_now_ns() - start);
    if (shared_.failed) {
      std::fprintf(stderr, "rig record: stopped: %s\n", shared_.error.c_str());
      return 1;
    }
    return 0;
  }

 private:
  static constexpr Nanos kExpirePeriodNs = 100'000'000;
  // What is missed is decided once a later sample of its topic came (record_gaps.hpp); this is for a
  // topic that went quiet. 1 s (rig monitor's loss timeout) counted samples a recorder catching up
  // after a 5 s stop received later: the repair of a fused cloud came > 1 s after its announcement.
  static constexpr Nanos kAnnouncedTimeoutNs = 5'000'000'000;
  static constexpr Nanos kAnnouncedAtStopNs = 200'000'000;
  static constexpr Nanos kMatchDelayNs = 500'000'000;  // a new reader takes this long to match its writers
  static constexpr int kStampsReaderDepth = 8192;       // ~2 MB of SourceStamps at most, ~20 s of a 10-device rig

  void expire(Nanos now, Nanos timeout_ns) { announced_.expire(now, timeout_ns); }

  // What a gap in a topic's SourceStamps.seq is (record_gaps.hpp), for announcements their writer did
  // not number (SourceStamps.published 0; numbered ones are exact on every topic). Samples published
  // and missed, unless the seq is a camera's device frame id (it also skips the frames the camera
  // made and the rig did not publish) or the dbw bridge's commands' (it stamps those it transmits,
  // not every one it takes; rig monitor counts no seq gap there either, monitor.cpp).
  static AnnouncedSamples::SeqGaps seq_gaps_of(const std::string& ros_name, const std::string& schema) {
    if (ros_name == "/vehicle/dbw/cmd") return AnnouncedSamples::SeqGaps::kNotCounted;
    if (schema == "sensor_msgs/msg/Image" || schema == "sensor_msgs/msg/CompressedImage") return AnnouncedSamples::SeqGaps::kUnannounced;
    return AnnouncedSamples::SeqGaps::kMissed;
  }

  // Each sample's header stamp, and /rig/stamps' announcements of samples of recorded topics.
  void note(const RecordTopic& t, const dds::RawSample& s) {
    const auto first = s.first();
    const auto order = record_cdr::order_of(first);
    if (!order) return;
    const auto body = s.in_shared_memory() ? s.second() : first.subspan(4);
    const Nanos now = monotonic_now_ns();
    if (t.ros_name != dds::kStampsTopic) {
      if (const auto stamp = record_cdr::header_stamp(body, *order)) announced_.on_data(t.ros_name, *stamp, now);
      return;
    }
    const auto a = record_cdr::source_stamps(body, *order);
    if (!a) return;
    const auto it = known_.find(std::string(a->topic));
    if (it == known_.end() || it->second == nullptr) return;
    // Samples written before this recorder's reader of the topic matched are not ours to miss (their
    // seq still tells where the topic's sequence stands).
    announced_.on_announced(it->first, a->stamp, a->seq, now, it->second->counting.admits(a->publish_ns), a->published);
  }

  void discover() {
    for (const auto& pub : discovery_.take()) {
      if (!pub.alive || pub.topic.rfind("rt/", 0) != 0) continue;
      const std::string ros = dds::dds_to_ros_topic(pub.topic);
      // Named topics restrict the recording; --raw adds every raw channel to them.
      const dds::RegisteredType* known_type = dds::find_type(pub.type);
      const bool raw = known_type != nullptr && is_raw_channel(known_type->schema_name);
      if (!wanted_.empty() && wanted_.count(ros) == 0 && !(raw && opt_.raw)) continue;
      if (known_.count(ros) != 0) {
        if (pub.reliability == dds::QosSpec::Reliability::kBestEffort && known_[ros] != nullptr && known_[ros]->reliable)
          std::fprintf(stderr, "rig record: %s: a best-effort writer joined a topic recorded reliably: its samples are not recorded\n", ros.c_str());
        continue;
      }
      const dds::RegisteredType* type = dds::find_type(pub.type);
      if (type == nullptr) {
        known_[ros] = nullptr;
        skipped_[ros] = "type " + pub.type + " is not known to the rig (no schema)";
        std::fprintf(stderr, "rig record: %s: not recorded: %s\n", ros.c_str(), skipped_[ros].c_str());
        continue;
      }
      if (raw && !opt_.raw && wanted_.count(ros) == 0) {
        known_[ros] = nullptr;  // never matched: its driver does not publish it (summary: "raw_off")
        raw_off_.insert(ros);
        continue;
      }
      dds::QosSpec q;
      q.reliability = pub.reliability;
      q.durability = pub.durability;
      q.depth = std::max(16, pub.depth);  // room for a burst while the thread takes another topic
      // /rig/stamps: every topic's announcements in one history. At the writer's 64 a recorder's
      // thread a moment behind lost announcements its reader had already received.
      if (ros == dds::kStampsTopic) q.depth = std::max(q.depth, kStampsReaderDepth);
      dds::QosSpec offered = q;
      offered.depth = pub.depth;
      RecordTopic& t = topics_.emplace_back();
      t.ros_name = ros;
      t.reliable = pub.reliability == dds::QosSpec::Reliability::kReliable;
      t.counting.since = vehicle_now_ns() + kMatchDelayNs;
      t.spec = {ros, type->schema_name, "ros2msg", type->schema, "cdr", {{"offered_qos_profiles", offered_qos_profiles({offered})}}};
      t.reader = std::make_unique<dds::RawReader>(participant_, pub.topic, *type, q);
      waitset_.attach_reader(t.reader->handle(), static_cast<std::int64_t>(topics_.size() - 1));
      known_[ros] = &t;
      announced_.set_seq_gaps(ros, seq_gaps_of(ros, type->schema_name));
    }
  }

  void take(RecordTopic& t) {
    RecordItem item;
    item.topic = &t;
    while (t.reader->take(item.sample)) {
      ++t.received;
      t.received_bytes += item.sample.size();
      note(t, item.sample);
      if (item.sample.in_shared_memory()) ++t.from_shared_memory;
      // Over shm a queued sample holds its publisher's iceoryx chunk: bounded per topic too.
      if (opt_.dds.transport == dds::Transport::kShm && t.queued >= opt_.topic_queue) {
        ++t.queue_dropped;
        continue;
      }
      ++t.queued;
      if (!queue_.push(std::move(item))) {
        --t.queued;
        ++t.queue_dropped;
      }
      item = RecordItem{};
      item.topic = &t;
    }
  }

  struct Totals {
    std::uint64_t received = 0, bytes = 0, written = 0, dds_lost = 0, dds_rejected = 0, malformed = 0, queue = 0, disk = 0,
                  missed = 0, unannounced = 0, overflow = 0;
  };
  Totals totals() {
    Totals s;
    for (auto& t : topics_) {
      s.received += t.received;
      s.bytes += t.received_bytes;
      s.written += t.written;
      s.dds_lost += t.reader->lost();
      const auto c = announced_.counts(t.ros_name);
      s.missed += c.missed;
      s.unannounced += c.unannounced;
      s.overflow += c.overflow;
      s.dds_rejected += t.reader->rejected();
      s.malformed += t.reader->malformed();
      s.queue += t.queue_dropped;
      s.disk += t.disk_dropped;
    }
    return s;
  }

  void progress(Nanos elapsed) {
    for (auto& t : topics_) t.reader->update_status();
    const Totals s = totals();
    const double dt = static_cast<double>(elapsed - last_elapsed_) / 1e9;
    const double rate = dt > 0 ? static_cast<double>(s.received - last_.received) / dt : 0;
    const double mbs_in = dt > 0 ? static_cast<double>(s.bytes - last_.bytes) / dt / 1e6 : 0;
    const auto file_bytes = shared_.file_bytes.load();
    const double mbs_out = dt > 0 ? static_cast<double>(file_bytes - last_file_bytes_) / dt / 1e6 : 0;
    std::fprintf(stderr,
                 "rig record: %6.1f s  %zu topics  %8.1f msg/s  %7.1f MB/s in  %7.1f MB/s to disk  %" PRIu64
                 " file(s) %.1f MB  queue %.1f MB  drops: dds %" PRIu64 " missed %" PRIu64 " queue %" PRIu64 " disk %" PRIu64 "%s\n",
                 static_cast<double>(elapsed) / 1e9, topics_.size(), rate, mbs_in, mbs_out, shared_.files.load(),
                 static_cast<double>(file_bytes) / 1e6, static_cast<double>(queue_.bytes()) / 1e6,
                 s.dds_lost + s.dds_rejected + s.malformed, s.missed, s.queue, s.disk, missed_by_topic().c_str());
    last_ = s;
    last_elapsed_ = elapsed;
    last_file_bytes_ = file_bytes;
  }

  // The progress line's tail: which topics missed what (record_gaps.hpp), only those that did.
  std::string missed_by_topic() const {
    std::string missed, unannounced;
    for (const auto& t : topics_) {
      const auto c = announced_.counts(t.ros_name);
      if (c.missed > 0) missed += (missed.empty() ? "" : ", ") + t.ros_name + " " + std::to_string(c.missed);
      if (c.unannounced > 0) unannounced += (unannounced.empty() ? "" : ", ") + t.ros_name + " " + std::to_string(c.unannounced);
    }
    std::string out;
    if (!missed.empty()) out += "  missed: " + missed;
    if (!unannounced.empty()) out += "  unannounced: " + unannounced;
    return out;
  }

  void summary(Nanos elapsed) {
    const Totals s = totals();
    nlohmann::json j;
    {
      std::lock_guard lock(shared_.mu);
      j["files"] = shared_.file_names;
    }
    j["seconds"] = static_cast<double>(elapsed) / 1e9;
    j["received"] = s.received;
    j["written"] = s.written;
    j["bytes_received"] = s.bytes;
    j["file_bytes"] = shared_.file_bytes.load();
    j["chunks"] = shared_.chunks.load();
    j["compression"] = std::string(record::mcap_name(opt_.compression).empty() ? "none" : record::mcap_name(opt_.compression));
    j["writer_ms"] = {{"compress", static_cast<double>(shared_.compress_ns.load()) / 1e6},
                      {"write", static_cast<double>(shared_.write_ns.load()) / 1e6},
                      {"metadata", static_cast<double>(shared_.metadata_ns.load()) / 1e6}};
    j["drops"] = {{"dds_lost", s.dds_lost}, {"dds_rejected", s.dds_rejected}, {"malformed", s.malformed}, {"missed", s.missed},
                  {"queue_full", s.queue}, {"disk", s.disk}};
    // Not drops: an upper bound on what else the recorder missed (record_gaps.hpp), and how often the
    // missed bookkeeping's bounds decided early.
    j["unannounced"] = s.unannounced;
    j["missed_overflow"] = s.overflow;
    for (auto& t : topics_) {
      const auto c = announced_.counts(t.ros_name);
      j["topics"][t.ros_name] = {{"type", t.spec.schema_name}, {"received", t.received}, {"written", t.written.load()},
                                 {"dds_lost", t.reader->lost()}, {"dds_rejected", t.reader->rejected()},
                                 {"malformed", t.reader->malformed()}, {"missed", c.missed}, {"unannounced", c.unannounced},
                                 {"missed_overflow", c.overflow}, {"queue_full", t.queue_dropped},
                                 {"disk", t.disk_dropped.load()}, {"shared_memory", t.from_shared_memory}};
    }
    for (const auto& [topic, why] : skipped_) j["skipped"][topic] = why;
    for (const auto& topic : raw_off_) j["raw_off"].push_back(topic);
    for (const auto& w : wanted_)
      if (known_.count(w) == 0) j["not_seen"].push_back(w);
    if (shared_.failed) j["error"] = shared_.error;
    std::printf("%s\n", j.dump().c_str());
    std::fflush(stdout);
  }

  const RecordOptions& opt_;
  dds::Participant participant_;
  dds::DiscoveryReader discovery_;
  dds::WaitSet waitset_;
  RecordQueue queue_;
  WriterShared shared_;
  std::set<std::string> wanted_;
  std::deque<RecordTopic> topics_;  // stable addresses: queued items point at their topic
  std::map<std::string, RecordTopic*> known_;  // nullptr: skipped
  std::map<std::string, std::string> skipped_;
  std::set<std::string> raw_off_;  // raw channels seen and not recorded (no --raw)
  AnnouncedSamples announced_;     // what the recorder missed (record_gaps.hpp)
  Totals last_;
  Nanos last_elapsed_ = 0;
  std::uint64_t last_file_bytes_ = 0;
};

}  // namespace

bool is_raw_channel(const std::string& schema_name) {
  return schema_name == "sensor_rig_msgs/msg/LidarPackets" || schema_name == "sensor_rig_msgs/msg/CanFrame";
}

int run_record(const RecordOptions& o) {
  record::SplitOptions so;
  so.out = o.out;
  so.split_bytes = o.split_mb << 20;
  so.split_ns = static_cast<Nanos>(o.split_s * 1e9);
  so.mcap.compression = o.compression;
  so.mcap.chunk_size = o.chunk_kb << 10;
  so.mcap.library = "sensor-rig rig record";
  record::SplitWriter out(so);  // throws McapError: the caller reports it
  RecordOptions with_rt = o;
  with_rt.dds.realtime_priority = o.rt_priority;  // Cyclone's receive/delivery threads too
  Recorder r(with_rt);
  return r.run(out);
}

}  // namespace sensor_rig::rig
