#include "monitor.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <string_view>

#include "latency_plot.hpp"
#include "monitor_stats.hpp"
#include "sample_record.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/dds/discovery.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/dds/reader_status.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/dds/view_reader.hpp"
#include "sensor_rig/dds/waitset.hpp"

namespace sensor_rig::rig {
namespace {

constexpr Nanos kLoopWaitNs = 20'000'000;
constexpr Nanos kMatchDelayNs = 500'000'000;  // a new reader takes this long to match its writers

template <class... A>
std::string fmt(const char* f, A... a) {
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"  // only called with literals below
  char buf[256];
  std::snprintf(buf, sizeof buf, f, a...);
#pragma GCC diagnostic pop
  return buf;
}

nlohmann::json percentiles_json(const Percentiles& p, bool with_n) {
  nlohmann::json j{{"p50", p.p50}, {"p99", p.p99}, {"max", p.max}};
  if (with_n) j["n"] = p.n;
  return j;
}

// Header stamp, payload size and a few words about the last sample, per message type (clouds and
// images only with the hidden `--reader copy`: by default they are read as views, below).
template <class T>
struct Inspect;
template <class T>
struct InspectHeader {
  static Nanos stamp(const T& m) { return msg::from_time(m.header.stamp); }
  static std::size_t size(const T& m) {
    if constexpr (requires { m.data._length; }) return m.data._length;
    return sizeof(T);  // control and state: fixed size, the C struct as an estimate
  }
};
template <>
struct Inspect<msg::PointCloud2> : InspectHeader<msg::PointCloud2> {
  static std::string info(const msg::PointCloud2& m) { return std::to_string(m.width * m.height) + " points"; }
};
template <>
struct Inspect<msg::Image> : InspectHeader<msg::Image> {
  static std::string info(const msg::Image& m) {
    return std::to_string(m.width) + "x" + std::to_string(m.height) + " " + (m.encoding ? m.encoding : "");
  }
};
template <>
struct Inspect<msg::CompressedImage> : InspectHeader<msg::CompressedImage> {
  static std::string info(const msg::CompressedImage& m) { return m.format ? m.format : ""; }
};
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
    return fmt("%.2f m/s, steering %.3f rad, yaw rate %.3f rad/s, gear %d", m.speed, m.steering_angle, m.yaw_rate,
               static_cast<int>(m.gear));
  }
};

// Reader QoS for the rig's topics: keep-last 16 (a burst must not overwrite what the loop has not taken).
dds::QosSpec reader_qos(dds::QosSpec::Reliability reliability) {
  dds::QosSpec q;
  q.depth = 16;
  q.reliability = reliability;
  return q;
}

// One subscribed topic, type-erased: poll() takes its samples into its stats.
class TopicReader {
 public:
  virtual ~TopicReader() = default;
  virtual void poll(TopicStats& stats) = 0;
};

template <class T>
class TypedReader final : public TopicReader {
 public:
  TypedReader(const dds::Participant& p, const std::string& ros_name, const dds::QosSpec& q, dds::WaitSet& ws)
      : topic_(p, ros_name, q), reader_(p, topic_, q) {
    ws.attach_reader(reader_.handle(), 0);  // wake at once: polling would add its period to the latency
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
};

// Clouds and images: the monitor needs the header, the size and a few words, never the data, so
// it reads the serialized sample in place (over shm: in the iceoryx chunk) instead of copying
// megabytes per sample. The `dds` stage ends once the view is parsed: the sample is usable.
// Malformed samples are dropped, counted in the stats and warned about.
template <class T, class View>
class ViewReader final : public TopicReader {
 public:
  ViewReader(const dds::Participant& p, const std::string& ros_name, const dds::QosSpec& q, dds::WaitSet& ws)
      : topic_(p, ros_name, q), reader_(p, topic_, q) {
    ws.attach_reader(reader_.handle(), 0);
  }
  void poll(TopicStats& stats) override {
    dds::take_views(reader_.handle(), view_, counts_, [&](const View& v, const dds_sample_info_t& info) {
      const Nanos stamp = static_cast<Nanos>(v.header.sec) * 1'000'000'000 + static_cast<Nanos>(v.header.nanosec);
      stats.on_data(stamp, v.data.size(), Arrival{vehicle_now_ns(), static_cast<Nanos>(info.source_timestamp)});
      stats.info = describe(v);
    });
    stats.reader_lost = dds::reader_samples_lost(reader_.handle());
    if (counts_.malformed > stats.malformed) {
      log::warn("monitor", topic_.ros_name() + ": " + std::to_string(counts_.malformed - stats.malformed) +
                               " malformed sample(s) dropped (" + dds::to_string(counts_.last_error) + ")");
      stats.malformed = counts_.malformed;
    }
  }

 private:
  static std::string describe(const dds::PointCloud2View& v) {
    return std::to_string(static_cast<std::uint64_t>(v.width) * v.height) + " points";
  }
  static std::string describe(const dds::ImageView& v) {
    return std::to_string(v.width) + "x" + std::to_string(v.height) + " " + std::string(v.encoding);
  }

  dds::Topic<T> topic_;
  dds::Reader<T> reader_;
  View view_;
  dds::ViewCounts counts_;
};

using ReaderFactory = std::function<std::unique_ptr<TopicReader>(const dds::Participant&, const std::string&,
                                                                  const dds::QosSpec&, dds::WaitSet&)>;
template <class Reader>
ReaderFactory factory() {
  return [](const dds::Participant& p, const std::string& n, const dds::QosSpec& q, dds::WaitSet& ws) {
    return std::make_unique<Reader>(p, n, q, ws);
  };
}
const std::map<std::string, ReaderFactory, std::less<>>& known_types() {
  static const std::map<std::string, ReaderFactory, std::less<>> kTypes = {
      {"sensor_msgs::msg::dds_::PointCloud2_", factory<ViewReader<msg::PointCloud2, dds::PointCloud2View>>()},
      {"sensor_msgs::msg::dds_::Image_", factory<ViewReader<msg::Image, dds::ImageView>>()},
      // The cameras announce their JPEGs on /rig/stamps (drivers/camera image_outputs.cpp): the monitor
      // reads them to join each with its stamps, so a JPEG announced and never delivered is lost here.
      // (Not reading them would not make them lost: stamps of a topic without a reader are never
      // counted, TopicStats::counting, but then nobody would count what the rig lost of them.)
      // Copied by dds_take (header stamp, format, size; no view parser for CompressedImage): a JPEG
      // is a fraction of its image_raw frame, which the monitor reads in place.
      {"sensor_msgs::msg::dds_::CompressedImage_", factory<TypedReader<msg::CompressedImage>>()},
      {"sensor_rig_msgs::msg::dds_::DbwCommand_", factory<TypedReader<msg::DbwCommand>>()},
      {"sensor_rig_msgs::msg::dds_::DbwStatus_", factory<TypedReader<msg::DbwStatus>>()},
      {"sensor_rig_msgs::msg::dds_::VehicleState_", factory<TypedReader<msg::VehicleState>>()},
  };
  return kTypes;
}
// `--reader copy` (hidden; before/after measurements side by side): clouds and images deserialized
// by dds_take, as the monitor read them before the views.
const std::map<std::string, ReaderFactory, std::less<>>& copying_types() {
  static const std::map<std::string, ReaderFactory, std::less<>> kTypes = {
      {"sensor_msgs::msg::dds_::PointCloud2_", factory<TypedReader<msg::PointCloud2>>()},
      {"sensor_msgs::msg::dds_::Image_", factory<TypedReader<msg::Image>>()},
  };
  return kTypes;
}
constexpr std::string_view kSyncSetType = "sensor_rig_msgs::msg::dds_::SyncSet_";

class SetReader {
 public:
  SetReader(const dds::Participant& p, const std::string& ros_name, dds::WaitSet& ws)
      : topic_(p, ros_name, reader_qos({})), reader_(p, topic_, reader_qos({})) {
    ws.attach_reader(reader_.handle(), 0);
  }
  void poll(SetStats& stats) {
    reader_.take([&](const msg::SyncSet& m, const dds_sample_info_t&) { stats.on_set(m); }, 256);
  }

 private:
  dds::Topic<msg::SyncSet> topic_;
  dds::Reader<msg::SyncSet> reader_;
};

class Monitor {
 public:
  explicit Monitor(const MonitorOptions& o)
      : opt_(o),
        participant_(o.dds, o.security),
        stamps_topic_(participant_, dds::kStampsTopic, dds::stamps_qos()),
        stamps_reader_(participant_, stamps_topic_, dds::stamps_qos()),
        discovery_(participant_),
        wanted_(o.topics.begin(), o.topics.end()) {
    waitset_.attach_reader(stamps_reader_.handle(), 0);
    waitset_.attach_reader(discovery_.handle(), 0);
    if (!o.record_file.empty()) record_.emplace(o.record_file);
    recording_ = record_ || !o.plot_file.empty();
  }

  int run() {
    const Nanos start = monotonic_now_ns();
    const Nanos period_ns = static_cast<Nanos>(opt_.period_ms) * 1'000'000;
    const Nanos loss_timeout_ns = static_cast<Nanos>(opt_.loss_timeout_s * 1e9);
    Nanos next_report = start + period_ns;
    Nanos last_report = start;
    const bool tty = !opt_.json && ::isatty(STDOUT_FILENO) != 0;
    std::vector<std::int64_t> woken;
    while (!shutdown_requested()) {
      discover();
      waitset_.wait(woken, kLoopWaitNs);
      take_stamps();
      for (auto& [name, reader] : readers_) reader->poll(stats_[name]);
      for (auto& [name, reader] : set_readers_) reader->poll(sets_[name]);
      take_set_diagnostics();
      // Recording needs every loss decided soon (rows in seq order); the table only once a period.
      const Nanos mono = monotonic_now_ns();
      if (recording_ || mono >= next_report)
        for (auto& [name, st] : stats_) st.expire(vehicle_now_ns(), loss_timeout_ns);
      if (record_) record_->flush();
      if (mono >= next_report) {
        report(static_cast<double>(mono - last_report) * 1e-9, tty);
        last_report = mono;
        next_report += period_ns;
      }
      if (opt_.duration_s > 0 && static_cast<double>(mono - start) * 1e-9 >= opt_.duration_s) break;
      if (opt_.keep_going && !opt_.keep_going()) break;
    }
    for (auto& [name, st] : stats_) st.release_all();
    if (record_) record_->flush();
    if (!opt_.plot_file.empty()) write_latency_plot(opt_.plot_file, plot_records_);
    if (!opt_.summary_file.empty()) write_summary(static_cast<double>(monotonic_now_ns() - start) * 1e-9);
    return 0;
  }

 private:
  TopicStats& topic(const std::string& name) {
    auto [it, added] = stats_.try_emplace(name);
    if (added) {
      it->second.name = name;
      if (recording_) it->second.on_record = [this](const SampleRecord& r) { keep(r); };
    }
    return it->second;
  }

  void keep(const SampleRecord& r) {
    if (record_) record_->add(r);
    if (!opt_.plot_file.empty()) plot_records_.push_back(r);
  }

  void take_stamps() {
    const Nanos now = vehicle_now_ns();
    stamps_reader_.take(
        [&](const msg::SourceStamps& s, const dds_sample_info_t& info) {
          const std::string name = s.topic != nullptr ? s.topic : "";
          if (!wanted_.empty() && !wanted_.contains(name)) return;
          TopicStats& st = topic(name);
          // Stamps lost with their data are seen only as a gap in the writer's sequence numbers. Sensor
          // topics only: the bridge stamps the commands it transmits, not every command it takes, so
          // its sequence numbers skip by design.
          auto [it, first] = next_seq_.try_emplace({name, info.publication_handle}, s.seq + 1);
          if (!first && name.rfind("/sensors/", 0) == 0) {
            if (s.seq > it->second && st.counting.admits(s.publish_ns)) {
              st.lost += s.seq - it->second;
              st.seq_gaps += s.seq - it->second;
            }
            it->second = std::max(it->second, s.seq + 1);
          }
          st.on_stamps(s, now);
        },
        1024);
  }

  // Incomplete and dropped sets: the rig's /diagnostics status rig/sets/<name>.
  void take_set_diagnostics() {
    diagnostics_reader_.take(
        [&](const msg::DiagnosticArray& a, const dds_sample_info_t&) {
          for (std::uint32_t i = 0; i < a.status._length; ++i) {
            const auto& st = a.status._buffer[i];
            if (st.name != nullptr && std::string_view(st.name).rfind("camera/", 0) == 0) {
              take_trigger_status(st);
              take_camera_drops(st);
            }
            take_counted_lost(st);
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
  }

  // Units a node counted lost itself (`counted_lost`, `scans_lost`, `frames_lost`), and the turns a
  // LIDAR heard nothing in (`scans_unheard`), on its topic.
  void take_counted_lost(const msg::DiagnosticStatus& st) {
    const char* topic_name = nullptr;
    const char* lost = nullptr;
    const char* unheard = nullptr;
    for (std::uint32_t k = 0; k < st.values._length; ++k) {
      const auto& kv = st.values._buffer[k];
      if (kv.key == nullptr || kv.value == nullptr) continue;
      const std::string_view key(kv.key);
      if (key == "topic") topic_name = kv.value;
      // A node's own total: counted_lost (camera nodes), else scans_lost (LIDAR) or frames_lost.
      if (key == "counted_lost" || ((key == "scans_lost" || key == "frames_lost") && lost == nullptr)) lost = kv.value;
      if (key == "scans_unheard") unheard = kv.value;
    }
    if (topic_name == nullptr) return;
    const auto it = stats_.find(topic_name);
    if (it == stats_.end()) return;
    if (lost != nullptr) it->second.on_counted_lost(std::strtoull(lost, nullptr, 10));
    if (unheard != nullptr) it->second.on_unheard(std::strtoull(unheard, nullptr, 10));
  }

  // A camera's drops by stage (its node's counters), on its image_raw topic if this monitor reads it.
  void take_camera_drops(const msg::DiagnosticStatus& st) {
    std::map<std::string, std::string, std::less<>> values;
    for (std::uint32_t k = 0; k < st.values._length; ++k) {
      const auto& kv = st.values._buffer[k];
      if (kv.key != nullptr && kv.value != nullptr) values.emplace(kv.key, kv.value);
    }
    const auto topic_it = values.find("topic");
    if (topic_it == values.end()) return;
    if (auto it = stats_.find(topic_it->second); it != stats_.end()) it->second.camera.on_status(values);
  }

  // A LIDAR-triggered camera's phase error (camera/<name> with trigger_lidar).
  void take_trigger_status(const msg::DiagnosticStatus& st) {
    TriggerStats t;
    for (std::uint32_t k = 0; k < st.values._length; ++k) {
      const auto& kv = st.values._buffer[k];
      if (kv.key != nullptr && kv.value != nullptr) (void)t.on_value(kv.key, kv.value);
    }
    if (!t.lidar.empty()) triggers_[st.name] = t;  // a camera without a LIDAR trigger: not shown
  }

  // Subscribes to every newly announced topic of a known type, with its writer's reliability.
  void discover() {
    for (const auto& pub : discovery_.take()) {
      if (!pub.alive) continue;
      const std::string ros = dds::dds_to_ros_topic(pub.topic);
      if (readers_.contains(ros) || set_readers_.contains(ros) || ros == dds::kStampsTopic) continue;
      if (!wanted_.empty() && !wanted_.contains(ros)) continue;
      if (pub.type == kSyncSetType) {
        set_readers_.emplace(ros, std::make_unique<SetReader>(participant_, ros, waitset_));
        sets_[ros];
        continue;
      }
      const auto it = known_types().find(pub.type);
      if (it == known_types().end()) continue;
      const auto copying = opt_.copy_clouds ? copying_types().find(pub.type) : copying_types().end();
      const ReaderFactory& make = copying != copying_types().end() ? copying->second : it->second;
      readers_.emplace(ros, make(participant_, ros, reader_qos(pub.reliability), waitset_));
      // Samples published before the new reader matches are not ours to count.
      topic(ros).counting.since = vehicle_now_ns() + kMatchDelayNs;
    }
  }

  void write_summary(double run_s) {
    nlohmann::json all = nlohmann::json::array();
    for (auto& [name, st] : stats_) {
      nlohmann::json j{{"topic", name},         {"duration_s", run_s},
                       {"received", st.received}, {"lost", st.lost},
                       {"source_drops", st.source_drops}, {"missing_packets", st.missing_packets},
                       {"counted_lost", st.counted_lost()}, {"unheard", st.unheard()},
                       {"size_bytes", st.last_size}};
      if (st.malformed > 0) j["malformed"] = st.malformed;
      j["drops_by_stage"] = drops_json(st);
      nlohmann::json lat = nlohmann::json::object();
      for (std::size_t i = 0; i < kStageCount; ++i) {
        const auto p = st.run_stages[i].take();
        if (p.n > 0) lat[kStageNames[i]] = percentiles_json(p, true);
      }
      j["latency_ms"] = lat;
      all.push_back(j);
    }
    for (auto& [name, st] : sets_) {
      const auto p = st.run_spread.take();
      nlohmann::json j{{"set", name}, {"duration_s", run_s}, {"received", st.received}, {"lost", st.lost},
                       {"incomplete", st.incomplete}, {"dropped", st.dropped}};
      if (p.n > 0) j["spread_ms"] = percentiles_json(p, true);
      all.push_back(j);
    }
    for (const auto& [name, t] : triggers_) all.push_back(trigger_json(name, t));
    std::ofstream(opt_.summary_file) << all.dump(2) << "\n";
  }

  static double rate(std::uint64_t n, double window_s) {
    return window_s > 0 ? static_cast<double>(n) / window_s : 0.0;
  }

  void report(double window_s, bool tty) {
    std::ostringstream table;
    if (tty) table << "\x1b[H\x1b[2J";
    if (!opt_.json)
      table << fmt("%-30s %7s %8s %7s %5s %5s %5s | %-13s %-13s %-13s %-15s | %s\n", "topic", "rate", "size", "recv",
                   "lost", "drops", "miss", "sensor ms", "process ms", "dds ms", "total ms",
                   "last sample (latencies: p50/p99)");
    for (auto& [name, st] : stats_) {
      if (!st.has_stamps && st.received == 0 && !readers_.contains(name)) continue;
      std::array<Percentiles, kStageCount> p;
      for (std::size_t i = 0; i < kStageCount; ++i) p[i] = st.stages[i].take();
      if (opt_.json) print_topic_json(name, st, rate(st.received_window, window_s), p);
      else table << topic_row(name, st, rate(st.received_window, window_s), p);
      st.received_window = 0;
    }
    report_sets(window_s, table);
    report_triggers(table);
    if (!opt_.json) report_camera_drops(table);
    if (!opt_.json) {
      if (stats_.empty()) table << "(waiting for publishers...)\n";
      if (!tty) table << "\n";
      std::fputs(table.str().c_str(), stdout);
    }
    std::fflush(stdout);
  }

  static void print_topic_json(const std::string& name, const TopicStats& st, double hz,
                               const std::array<Percentiles, kStageCount>& p) {
    nlohmann::json lat = nlohmann::json::object();
    for (std::size_t i = 0; i < kStageCount; ++i)
      if (p[i].n > 0) lat[kStageNames[i]] = percentiles_json(p[i], false);
    nlohmann::json j{{"topic", name},       {"rate_hz", std::round(hz * 100) / 100},
                     {"size_bytes", st.last_size}, {"received", st.received},
                     {"lost", st.lost},     {"source_drops", st.source_drops},
                     {"missing_packets", st.missing_packets},
                     {"counted_lost", st.counted_lost()},
                     {"unheard", st.unheard()},
                     {"info", st.info},     {"latency_ms", lat}};
    if (st.seq_gaps > 0) j["seq_gaps"] = st.seq_gaps;
    if (st.malformed > 0) j["malformed"] = st.malformed;
    j["drops_by_stage"] = drops_json(st);
    std::printf("%s\n", j.dump().c_str());
  }

  static std::string topic_row(const std::string& name, const TopicStats& st, double hz,
                               const std::array<Percentiles, kStageCount>& p) {
    const auto cell = [&](Stage s) { return p[s].n == 0 ? std::string("-") : fmt("%.2f/%.2f", p[s].p50, p[s].p99); };
    // miss: packets the sensor sent for these samples and the driver never got (LIDAR scans).
    const std::string miss = st.has_stamps ? std::to_string(st.missing_packets) : "-";
    return fmt("%-30s %5.1fHz %7.1fk %7llu %5llu %5llu %5s | %-13s %-13s %-13s %-15s | ", name.c_str(), hz,
               static_cast<double>(st.last_size) / 1024.0, static_cast<unsigned long long>(st.received),
               static_cast<unsigned long long>(st.lost), static_cast<unsigned long long>(st.source_drops),
               miss.c_str(), cell(kSensor).c_str(), cell(kProcess).c_str(), cell(kDds).c_str(),
               cell(kTotal).c_str()) +
           (p[kEcu].n == 0 ? std::string() : "ecu " + cell(kEcu) + " ms  ") +
           // Turns nothing was heard in, lost or never made: the node cannot tell (stream_gap.hpp).
           (st.unheard() == 0 ? std::string() : "unheard " + std::to_string(st.unheard()) + " turns  ") + st.info + "\n";
  }

  // Synchronized sets, below the topics: rate, spread p50/p99/max, incomplete (from /diagnostics).
  void report_sets(double window_s, std::ostringstream& table) {
    if (sets_.empty()) return;
    if (!opt_.json)
      table << fmt("%-30s %7s %7s %10s %7s | %s\n", "set", "rate", "recv", "incomplete", "dropped",
                   "spread ms p50/p99/max");
    for (auto& [name, st] : sets_) {
      const double hz = rate(st.received_window, window_s);
      const auto p = st.spread.take();
      if (opt_.json) {
        nlohmann::json j{{"set", name},          {"rate_hz", std::round(hz * 100) / 100}, {"members", st.members},
                         {"received", st.received}, {"lost", st.lost},
                         {"incomplete", st.incomplete}, {"dropped", st.dropped}};
        if (p.n > 0) j["spread_ms"] = percentiles_json(p, false);
        std::printf("%s\n", j.dump().c_str());
      } else {
        table << fmt("%-30s %5.1fHz %7llu %10llu %7llu | ", name.c_str(), hz,
                     static_cast<unsigned long long>(st.received), static_cast<unsigned long long>(st.incomplete),
                     static_cast<unsigned long long>(st.dropped))
              << (p.n > 0 ? fmt("%.2f/%.2f/%.2f", p.p50, p.p99, p.max) : std::string("-")) << "\n";
      }
      st.received_window = 0;
    }
  }

  static nlohmann::json drops_json(const TopicStats& st) {
    nlohmann::json j = nlohmann::json::object();
    for (const auto& [stage, n] : drops_by_stage(st)) j[std::string(stage)] = n;
    return j;
  }

  // Cameras, below the triggers: where each frame that did not arrive went, stage by stage.
  void report_camera_drops(std::ostringstream& table) const {
    bool header = false;
    for (const auto& [name, st] : stats_) {
      if (!st.camera.seen) continue;
      const auto drops = drops_by_stage(st);
      if (!header) {
        table << fmt("%-30s", "camera drops by stage");
        for (const auto& [stage, n] : drops) table << " " << stage;
        table << "\n";
        header = true;
      }
      table << fmt("%-30s", name.c_str());
      for (const auto& [stage, n] : drops) table << fmt(" %*llu", static_cast<int>(stage.size()), static_cast<unsigned long long>(n));
      table << "\n";
    }
  }

  // LIDAR-triggered cameras, below the sets: |exposure start - sweep crossing| as the node measures
  // it, where that exposure start comes from, and its host / camera parts.
  void report_triggers(std::ostringstream& table) {
    if (triggers_.empty()) return;
    if (!opt_.json) table << trigger_table_header();
    for (const auto& [name, t] : triggers_) {
      if (opt_.json) std::printf("%s\n", trigger_json(name, t).dump().c_str());
      else table << trigger_table_row(name, t);
    }
  }

  MonitorOptions opt_;
  dds::Participant participant_;
  dds::Topic<msg::SourceStamps> stamps_topic_;
  dds::Reader<msg::SourceStamps> stamps_reader_;
  std::map<std::pair<std::string, dds_instance_handle_t>, std::uint64_t> next_seq_;  // per (topic, writer)
  dds::DiscoveryReader discovery_;
  std::set<std::string> wanted_;
  std::optional<RecordFile> record_;
  bool recording_ = false;                  // --record or --plot: every sample decided as it goes
  std::vector<SampleRecord> plot_records_;  // --plot: the whole run
  std::map<std::string, std::unique_ptr<TopicReader>> readers_;
  std::map<std::string, TopicStats> stats_;
  dds::Topic<msg::DiagnosticArray> diagnostics_topic_{participant_, "/diagnostics"};
  dds::Reader<msg::DiagnosticArray> diagnostics_reader_{participant_, diagnostics_topic_};
  std::map<std::string, std::unique_ptr<SetReader>> set_readers_;
  std::map<std::string, SetStats> sets_;
  std::map<std::string, TriggerStats> triggers_;  // by status name camera/<name>
  // Last: destroyed first, its read conditions before the readers they belong to.
  dds::WaitSet waitset_{participant_};
};

}  // namespace

int run_monitor(const MonitorOptions& options) {
  Monitor m(options);
  return m.run();
}

}  // namespace sensor_rig::rig
