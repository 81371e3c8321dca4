#include "monitor.hpp"

#include <unistd.h>

#include <cstdio>
#include <deque>
#include <limits>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string_view>

#include "sensor_rig/common/latency_window.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"

namespace sensor_rig::rig {
namespace {

constexpr Nanos kLossTimeoutNs = 2'000'000'000;
constexpr const char* kStages[] = {"sensor", "assemble", "process", "write", "dds", "total", "to_wire"};
enum Stage : std::size_t { kSensor, kAssemble, kProcess, kWrite, kDds, kTotal, kToWire };
constexpr std::size_t kStageCount = std::size(kStages);

double ms(Nanos ns) { return static_cast<double>(ns) * 1e-6; }

struct Arrival {
  Nanos receive_ns = 0;
  Nanos publish_ns = 0;  // DDS source timestamp
};

// Everything known about one topic; fed by its data reader and by the stamps reader.
struct TopicStats {
  std::string name;
  std::string type;
  std::uint64_t received = 0, lost = 0, source_drops = 0, bytes_window = 0, received_window = 0;
  std::size_t last_size = 0;
  std::string info;  // what the last sample says, in a few words (points, speed, state...)
  std::array<LatencyWindow, kStageCount> stages;
  std::array<LatencyWindow, kStageCount> run_stages;  // whole run, for --summary
  // Matching data samples with their stamps by header stamp (ns). Either may come first.
  std::map<Nanos, Arrival> unmatched_data;
  std::map<Nanos, msg::SourceStamps> unmatched_stamps;  // strings not kept (topic only)
  bool has_stamps = false;
  // Stamps published before this monitor subscribed to the data topic cannot be matched: ignored.
  Nanos counting_since = std::numeric_limits<Nanos>::max();

  void on_data(Nanos stamp, std::size_t size, const Arrival& a) {
    ++received;
    ++received_window;
    bytes_window += size;
    last_size = size;
    add(kDds, ms(a.receive_ns - a.publish_ns));
    if (auto it = unmatched_stamps.find(stamp); it != unmatched_stamps.end()) {
      add_stages(it->second, a);
      unmatched_stamps.erase(it);
    } else {
      unmatched_data.emplace(stamp, a);
    }
  }
  void on_stamps(const msg::SourceStamps& s, Nanos now) {
    has_stamps = true;
    if (s.publish_ns < counting_since) return;
    source_drops += s.dropped;
    const Nanos stamp = msg::from_time(s.header.stamp);
    if (auto it = unmatched_data.find(stamp); it != unmatched_data.end()) {
      add_stages(s, it->second);
      unmatched_data.erase(it);
    } else {
      msg::SourceStamps copy = s;
      copy.topic = nullptr;
      copy.header.frame_id = nullptr;
      copy.ready_ns = now;  // reused as "seen at", for the loss timeout
      unmatched_stamps.emplace(stamp, copy);
    }
  }
  void add_stages(const msg::SourceStamps& s, const Arrival& a) {
    if (s.first_rx_ns > 0 && s.acquisition_ns > 0) add(kSensor, ms(s.first_rx_ns - s.acquisition_ns));
    if (s.first_rx_ns > 0 && s.last_rx_ns > 0) add(kAssemble, ms(s.last_rx_ns - s.first_rx_ns));
    if (s.last_rx_ns > 0) add(kProcess, ms(s.publish_ns - s.last_rx_ns));
    if (s.written_ns > 0) add(kWrite, ms(s.written_ns - s.publish_ns));
    if (s.written_ns > 0 && s.last_rx_ns > 0) add(kToWire, ms(s.written_ns - s.last_rx_ns));
    if (s.acquisition_ns > 0) add(kTotal, ms(a.receive_ns - s.acquisition_ns));
  }
  void add(std::size_t stage, double value) {
    stages[stage].add(value);
    run_stages[stage].add(value);
  }
  void expire(Nanos now) {
    for (auto it = unmatched_stamps.begin(); it != unmatched_stamps.end();) {
      if (now - it->second.ready_ns > kLossTimeoutNs) {
        ++lost;
        it = unmatched_stamps.erase(it);
      } else {
        ++it;
      }
    }
    for (auto it = unmatched_data.begin(); it != unmatched_data.end();)
      it = now - it->second.receive_ns > kLossTimeoutNs ? unmatched_data.erase(it) : std::next(it);
  }
};

// One synchronized set (/rig/sets/<name>): rate and spread from its samples, incomplete sets from
// the rig's /diagnostics (rig/sets/<name>: an incomplete set is never published).
struct SetStats {
  std::uint64_t received = 0, received_window = 0, incomplete = 0, dropped = 0, lost = 0;
  std::uint64_t next_seq = 0;
  bool any = false;
  std::size_t members = 0;
  LatencyWindow spread, run_spread;
  void on_set(const msg::SyncSet& m) {
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
};

// A reader of one data topic, type-erased: poll() takes samples and feeds TopicStats.
class TopicReader {
 public:
  virtual ~TopicReader() = default;
  virtual void poll(TopicStats& stats) = 0;
};

// Header stamp and payload size per message type the monitor understands.
template <class T>
struct Inspect;
template <>
struct Inspect<msg::PointCloud2> {
  static Nanos stamp(const msg::PointCloud2& m) { return msg::from_time(m.header.stamp); }
  static std::size_t size(const msg::PointCloud2& m) { return m.data._length; }
  static std::string info(const msg::PointCloud2& m) { return std::to_string(m.width * m.height) + " points"; }
};
template <>
struct Inspect<msg::Image> {
  static Nanos stamp(const msg::Image& m) { return msg::from_time(m.header.stamp); }
  static std::size_t size(const msg::Image& m) { return m.data._length; }
  static std::string info(const msg::Image& m) {
    return std::to_string(m.width) + "x" + std::to_string(m.height) + " " + (m.encoding ? m.encoding : "");
  }
};

// Control and state messages: fixed-size payload; report the C struct size as an estimate.
template <class T>
struct InspectHeader {
  static Nanos stamp(const T& m) { return msg::from_time(m.header.stamp); }
  static std::size_t size(const T&) { return sizeof(T); }
};
template <class... A>
std::string fmt(const char* f, A... a) {
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"  // only called with literals below
  char buf[96];
  std::snprintf(buf, sizeof buf, f, a...);
#pragma GCC diagnostic pop
  return buf;
}
template <>
struct Inspect<msg::DbwCommand> : InspectHeader<msg::DbwCommand> {
  static std::string info(const msg::DbwCommand& m) {
    return std::string(m.enable ? "enable " : "") + fmt("throttle %.2f steer %.3f rad", m.throttle, m.steering_angle);
  }
};
template <>
struct Inspect<msg::DbwStatus> : InspectHeader<msg::DbwStatus> {
  static std::string info(const msg::DbwStatus& m) {
    return std::string(m.state == 1 ? "ENGAGED" : "disengaged") + " (" + (m.reason ? m.reason : "") + ")";
  }
};
template <>
struct Inspect<msg::VehicleState> : InspectHeader<msg::VehicleState> {
  static std::string info(const msg::VehicleState& m) {
    return fmt("%.2f m/s, steering %.3f rad", m.speed, m.steering_angle) + fmt(", yaw rate %.3f rad/s, gear %d", m.yaw_rate, static_cast<int>(m.gear));
  }
};

template <class T>
class TypedReader final : public TopicReader {
 public:
  TypedReader(const dds::Participant& p, const std::string& ros_name, const dds::QosSpec& q, dds_entity_t waitset)
      : topic_(p, ros_name, q), reader_(p, topic_, q) {
    // Wake the monitor's loop as soon as a sample arrives: polling would add its period to the latency.
    cond_ = dds::Entity(dds::check(dds_create_readcondition(reader_.handle(), DDS_ANY_STATE), "readcondition"));
    dds::check(dds_waitset_attach(waitset, cond_.handle(), 0), "waitset attach");
  }
  void poll(TopicStats& stats) override {
    reader_.take(
        [&](const T& m, const dds_sample_info_t& info) {
          stats.on_data(Inspect<T>::stamp(m), Inspect<T>::size(m),
                        Arrival{vehicle_now_ns(), static_cast<Nanos>(info.source_timestamp)});
          stats.info = Inspect<T>::info(m);
        },
        256);
  }

 private:
  dds::Topic<T> topic_;
  dds::Reader<T> reader_;
  dds::Entity cond_;
};

using ReaderFactory = std::function<std::unique_ptr<TopicReader>(const dds::Participant&, const std::string&,
                                                                  const dds::QosSpec&, dds_entity_t)>;
template <class T>
ReaderFactory factory() {
  return [](const dds::Participant& p, const std::string& n, const dds::QosSpec& q, dds_entity_t ws) {
    return std::make_unique<TypedReader<T>>(p, n, q, ws);
  };
}
const std::map<std::string, ReaderFactory>& known_types() {
  static const std::map<std::string, ReaderFactory> types = {
      {"sensor_msgs::msg::dds_::PointCloud2_", factory<msg::PointCloud2>()},
      {"sensor_msgs::msg::dds_::Image_", factory<msg::Image>()},
      {"sensor_rig_msgs::msg::dds_::DbwCommand_", factory<msg::DbwCommand>()},
      {"sensor_rig_msgs::msg::dds_::DbwStatus_", factory<msg::DbwStatus>()},
      {"sensor_rig_msgs::msg::dds_::VehicleState_", factory<msg::VehicleState>()},
  };
  return types;
}

// The reader QoS that matches a discovered writer: same reliability, keep-last 16.
dds::QosSpec reader_qos_for(const dds_qos_t* writer_qos) {
  dds::QosSpec q;
  q.depth = 16;
  dds_reliability_kind_t kind = DDS_RELIABILITY_RELIABLE;
  dds_duration_t blocking = 0;
  if (writer_qos != nullptr && dds_qget_reliability(writer_qos, &kind, &blocking) && kind == DDS_RELIABILITY_BEST_EFFORT)
    q.reliability = dds::QosSpec::Reliability::kBestEffort;
  return q;
}

class SetReader {
 public:
  SetReader(const dds::Participant& p, const std::string& ros_name, dds_entity_t waitset)
      : topic_(p, ros_name, qos()), reader_(p, topic_, qos()) {
    cond_ = dds::Entity(dds::check(dds_create_readcondition(reader_.handle(), DDS_ANY_STATE), "readcondition"));
    dds::check(dds_waitset_attach(waitset, cond_.handle(), 0), "waitset attach");
  }
  static dds::QosSpec qos() {
    dds::QosSpec q;
    q.depth = 16;
    return q;
  }
  void poll(SetStats& stats) {
    reader_.take([&](const msg::SyncSet& m, const dds_sample_info_t&) { stats.on_set(m); }, 256);
  }

 private:
  dds::Topic<msg::SyncSet> topic_;
  dds::Reader<msg::SyncSet> reader_;
  dds::Entity cond_;
};

class Monitor {
 public:
  explicit Monitor(const MonitorOptions& o)
      : opt_(o),
        participant_(o.dds),
        stamps_topic_(participant_, dds::kStampsTopic, dds::stamps_qos()),
        stamps_reader_(participant_, stamps_topic_, dds::stamps_qos()) {
    waitset_ = dds::Entity(dds::check(dds_create_waitset(participant_.handle()), "waitset"));
    stamps_cond_ = dds::Entity(
        dds::check(dds_create_readcondition(stamps_reader_.handle(), DDS_ANY_STATE), "readcondition"));
    dds::check(dds_waitset_attach(waitset_.handle(), stamps_cond_.handle(), 0), "waitset attach");
    publications_ = dds::Entity(
        dds::check(dds_create_reader(participant_.handle(), DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr),
                   "builtin publication reader"));
    for (const auto& t : o.topics) wanted_.insert(t);
  }

  int run() {
    const Nanos start = monotonic_now_ns();
    Nanos next_report = start + static_cast<Nanos>(opt_.period_ms) * 1'000'000;
    Nanos last_report = start;
    const bool tty = !opt_.json && ::isatty(STDOUT_FILENO) != 0;
    while (!shutdown_requested()) {
      discover();
      dds_waitset_wait(waitset_.handle(), nullptr, 0, DDS_MSECS(20));
      const Nanos now = vehicle_now_ns();
      stamps_reader_.take(
          [&](const msg::SourceStamps& s, const dds_sample_info_t&) {
            const std::string topic = s.topic != nullptr ? s.topic : "";
            if (!wanted_.empty() && !wanted_.contains(topic)) return;
            auto& st = stats_[topic];
            st.name = topic;
            st.on_stamps(s, now);
          },
          1024);
      for (auto& [name, reader] : readers_) reader->poll(stats_[name]);
      for (auto& [name, reader] : set_readers_) reader->poll(sets_[name]);
      diagnostics_reader_.take(
          [&](const msg::DiagnosticArray& a, const dds_sample_info_t&) {
            for (std::uint32_t i = 0; i < a.status._length; ++i) {
              const auto& st = a.status._buffer[i];
              if (st.name == nullptr || std::string_view(st.name).rfind("rig/sets/", 0) != 0) continue;
              std::string set_topic = "/";  // appended, not "/" + name: GCC 12 -O3 false -Wrestrict
              set_topic += st.name;
              auto it = sets_.find(set_topic);
              if (it == sets_.end()) continue;
              for (std::uint32_t k = 0; k < st.values._length; ++k) {
                const auto& kv = st.values._buffer[k];
                if (kv.key == nullptr || kv.value == nullptr) continue;
                if (std::string_view(kv.key) == "incomplete") it->second.incomplete = std::strtoull(kv.value, nullptr, 10);
                if (std::string_view(kv.key) == "dropped") it->second.dropped = std::strtoull(kv.value, nullptr, 10);
              }
            }
          },
          16);
      const Nanos mono = monotonic_now_ns();
      if (mono >= next_report) {
        for (auto& [name, st] : stats_) st.expire(vehicle_now_ns());
        report(static_cast<double>(mono - last_report) * 1e-9, tty);
        last_report = mono;
        next_report += static_cast<Nanos>(opt_.period_ms) * 1'000'000;
      }
      if (opt_.duration_s > 0 && static_cast<double>(mono - start) * 1e-9 >= opt_.duration_s) break;
      if (opt_.keep_going && !opt_.keep_going()) break;
    }
    if (!opt_.summary_file.empty()) write_summary(static_cast<double>(monotonic_now_ns() - start) * 1e-9);
    return 0;
  }

 private:
  void discover() {
    void* ptrs[16] = {};
    dds_sample_info_t infos[16];
    const int n = dds_take(publications_.handle(), ptrs, infos, 16, 16);
    for (int i = 0; i < n; ++i) {
      if (!infos[i].valid_data) continue;
      const auto* ep = static_cast<const dds_builtintopic_endpoint_t*>(ptrs[i]);
      const std::string ros = dds::dds_to_ros_topic(ep->topic_name);
      if (readers_.contains(ros) || ros == dds::kStampsTopic) continue;
      if (!wanted_.empty() && !wanted_.contains(ros)) continue;
      if (std::string_view(ep->type_name) == "sensor_rig_msgs::msg::dds_::SyncSet_") {
        if (!set_readers_.contains(ros)) {
          set_readers_.emplace(ros, std::make_unique<SetReader>(participant_, ros, waitset_.handle()));
          sets_[ros];
        }
        continue;
      }
      const auto it = known_types().find(ep->type_name);
      if (it == known_types().end()) continue;
      readers_.emplace(ros, it->second(participant_, ros, reader_qos_for(ep->qos), waitset_.handle()));
      auto& st = stats_[ros];
      st.name = ros;
      st.type = ep->type_name;
      // Matching the new reader takes a moment; samples published before then are not ours to count.
      st.counting_since = vehicle_now_ns() + 500'000'000;
    }
    if (n > 0) dds_return_loan(publications_.handle(), ptrs, n);
  }

  void write_summary(double run_s) {
    nlohmann::json all = nlohmann::json::array();
    for (auto& [name, st] : stats_) {
      nlohmann::json j;
      j["topic"] = name;
      j["duration_s"] = run_s;
      j["received"] = st.received;
      j["lost"] = st.lost;
      j["source_drops"] = st.source_drops;
      j["size_bytes"] = st.last_size;
      nlohmann::json lat = nlohmann::json::object();
      for (std::size_t i = 0; i < kStageCount; ++i) {
        const auto p = st.run_stages[i].take();
        if (p.n > 0) lat[kStages[i]] = {{"p50", p.p50}, {"p99", p.p99}, {"max", p.max}, {"n", p.n}};
      }
      j["latency_ms"] = lat;
      all.push_back(j);
    }
    for (auto& [name, st] : sets_) {
      const auto p = st.run_spread.take();
      nlohmann::json j{{"set", name}, {"duration_s", run_s}, {"received", st.received}, {"lost", st.lost},
                       {"incomplete", st.incomplete}, {"dropped", st.dropped}};
      if (p.n > 0) j["spread_ms"] = {{"p50", p.p50}, {"p99", p.p99}, {"max", p.max}, {"n", p.n}};
      all.push_back(j);
    }
    std::ofstream(opt_.summary_file) << all.dump(2) << "\n";
  }

  void report(double window_s, bool tty) {
    std::ostringstream table;
    if (tty) table << "\x1b[H\x1b[2J";
    if (!opt_.json) {
      char line[512];
      std::snprintf(line, sizeof line, "%-30s %7s %8s %7s %5s %5s | %-13s %-13s %-13s %-15s | %s\n", "topic", "rate",
                    "size", "recv", "lost", "drops", "sensor ms", "process ms", "dds ms", "total ms",
                    "last sample (latencies: p50/p99)");
      table << line;
    }
    for (auto& [name, st] : stats_) {
      if (!st.has_stamps && st.received == 0 && !readers_.contains(name)) continue;
      const double rate = window_s > 0 ? static_cast<double>(st.received_window) / window_s : 0.0;
      std::array<Percentiles, kStageCount> p;
      for (std::size_t i = 0; i < kStageCount; ++i) p[i] = st.stages[i].take();
      if (opt_.json) {
        nlohmann::json j;
        j["topic"] = name;
        j["rate_hz"] = std::round(rate * 100) / 100;
        j["size_bytes"] = st.last_size;
        j["received"] = st.received;
        j["lost"] = st.lost;
        j["source_drops"] = st.source_drops;
        j["info"] = st.info;
        nlohmann::json lat = nlohmann::json::object();
        for (std::size_t i = 0; i < kStageCount; ++i)
          if (p[i].n > 0) lat[kStages[i]] = {{"p50", p[i].p50}, {"p99", p[i].p99}, {"max", p[i].max}};
        j["latency_ms"] = lat;
        std::printf("%s\n", j.dump().c_str());
      } else {
        auto cell = [&](std::size_t i) {
          char c[32];
          if (p[i].n == 0) return std::string("-");
          std::snprintf(c, sizeof c, "%.2f/%.2f", p[i].p50, p[i].p99);
          return std::string(c);
        };
        char line[512];
        std::snprintf(line, sizeof line, "%-30s %5.1fHz %7.1fk %7llu %5llu %5llu | %-13s %-13s %-13s %-15s | %s\n",
                      name.c_str(), rate, static_cast<double>(st.last_size) / 1024.0,
                      static_cast<unsigned long long>(st.received), static_cast<unsigned long long>(st.lost),
                      static_cast<unsigned long long>(st.source_drops), cell(kSensor).c_str(), cell(kProcess).c_str(),
                      cell(kDds).c_str(), cell(kTotal).c_str(), st.info.c_str());
        table << line;
      }
      st.received_window = 0;
      st.bytes_window = 0;
    }
    report_sets(window_s, table);
    if (!opt_.json) {
      if (stats_.empty()) table << "(waiting for publishers...)\n";
      if (!tty) table << "\n";
      std::fputs(table.str().c_str(), stdout);
    }
    std::fflush(stdout);
  }

  // Synchronized sets, below the topics: rate, spread p50/p99/max, incomplete (from /diagnostics).
  void report_sets(double window_s, std::ostringstream& table) {
    if (sets_.empty()) return;
    if (!opt_.json) {
      char line[256];
      std::snprintf(line, sizeof line, "%-30s %7s %7s %10s %7s | %s\n", "set", "rate", "recv", "incomplete", "dropped",
                    "spread ms p50/p99/max");
      table << line;
    }
    for (auto& [name, st] : sets_) {
      const double rate = window_s > 0 ? static_cast<double>(st.received_window) / window_s : 0.0;
      const auto p = st.spread.take();
      if (opt_.json) {
        nlohmann::json j;
        j["set"] = name;
        j["rate_hz"] = std::round(rate * 100) / 100;
        j["members"] = st.members;
        j["received"] = st.received;
        j["lost"] = st.lost;
        j["incomplete"] = st.incomplete;
        j["dropped"] = st.dropped;
        if (p.n > 0) j["spread_ms"] = {{"p50", p.p50}, {"p99", p.p99}, {"max", p.max}};
        std::printf("%s\n", j.dump().c_str());
      } else {
        char line[256];
        std::snprintf(line, sizeof line, "%-30s %5.1fHz %7llu %10llu %7llu | %s\n", name.c_str(), rate,
                      static_cast<unsigned long long>(st.received), static_cast<unsigned long long>(st.incomplete),
                      static_cast<unsigned long long>(st.dropped),
                      p.n > 0 ? fmt("%.2f/%.2f/%.2f", p.p50, p.p99, p.max).c_str() : "-");
        table << line;
      }
      st.received_window = 0;
    }
  }

  MonitorOptions opt_;
  dds::Participant participant_;
  dds::Topic<msg::SourceStamps> stamps_topic_;
  dds::Reader<msg::SourceStamps> stamps_reader_;
  dds::Entity waitset_;
  dds::Entity stamps_cond_;
  dds::Entity publications_;
  std::set<std::string> wanted_;
  std::map<std::string, std::unique_ptr<TopicReader>> readers_;
  std::map<std::string, TopicStats> stats_;
  dds::Topic<msg::DiagnosticArray> diagnostics_topic_{participant_, "/diagnostics"};
  dds::Reader<msg::DiagnosticArray> diagnostics_reader_{participant_, diagnostics_topic_};
  std::map<std::string, std::unique_ptr<SetReader>> set_readers_;
  std::map<std::string, SetStats> sets_;
};

}  // namespace

int run_monitor(const MonitorOptions& options) {
  Monitor m(options);
  return m.run();
}

}  // namespace sensor_rig::rig
