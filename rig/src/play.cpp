#include "play.hpp"
#include "sensor_rig/common/cli.hpp"

#include <time.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <thread>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>

#include "qos_profiles.hpp"
#include "recording_files.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/percentile.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/common/thread_priority.hpp"
#include "sensor_rig/dds/raw_topic.hpp"
#include "sensor_rig/dds/topic.hpp"
#include "sensor_rig/msgs/ros2msg.hpp"
#include "sensor_rig/record/mcap_reader.hpp"

namespace sensor_rig::rig {
namespace {

// Whether two ros2msg schemas describe the same fields (names, types, arrays), dependencies included.
std::string schema_difference(const std::string& name, const std::string& theirs, const std::string& ours) {
  try {
    const auto a = msgs::parse_ros2msg_schema(name, theirs);
    const auto b = msgs::parse_ros2msg_schema(name, ours);
    std::map<std::string, const msgs::MsgDefinition*> by_name;
    for (const auto& d : b) by_name[d.name] = &d;
    for (const auto& d : a) {
      const auto it = by_name.find(d.name);
      if (it == by_name.end()) continue;  // a dependency the rig's text names otherwise: checked through its user
      const auto& f1 = d.fields;
      const auto& f2 = it->second->fields;
      if (f1.size() != f2.size()) return d.name + " has " + std::to_string(f1.size()) + " fields, the rig's " + std::to_string(f2.size());
      for (std::size_t i = 0; i < f1.size(); ++i)
        if (f1[i].type != f2[i].type || f1[i].name != f2[i].name || f1[i].kind != f2[i].kind || f1[i].size != f2[i].size)
          return d.name + " field " + std::to_string(i) + " is '" + f1[i].type + " " + f1[i].name + "', the rig's '" +
                 f2[i].type + " " + f2[i].name + "'";
    }
    return {};
  } catch (const std::invalid_argument& e) {
    return std::string("schema does not parse: ") + e.what();
  }
}

struct PlayTopic {
  std::unique_ptr<dds::RawWriter> writer;
  std::uint64_t played = 0, write_errors = 0;
};

// A message read ahead; topic == nullptr marks the start of a pass (--loop).
struct Pending {
  PlayTopic* topic = nullptr;
  std::uint64_t log_time = 0;
  std::vector<std::byte> data;
};

}  // namespace

int run_play(const PlayOptions& o) {
  std::vector<std::string> files;
  try {
    files = recording_files(o.path);
  } catch (const std::runtime_error& e) {  // a folder without a recording
    throw cli::UsageError(e.what());
  }
  dds::Participant participant(o.dds);
  std::map<std::string, PlayTopic> topics;     // by ROS name
  std::map<std::string, std::string> refused;  // topic -> why
  const std::set<std::string> wanted(o.topics.begin(), o.topics.end());
  nlohmann::json problems = nlohmann::json::array();
  std::vector<std::unique_ptr<record::McapReader>> readers;
  for (const auto& f : files) {
    auto r = std::make_unique<record::McapReader>(f);  // McapError: not an MCAP file
    if (!r->complete()) r->load_channels_from_chunks();
    for (const auto& [id, ch] : r->channels()) {
      if ((!wanted.empty() && wanted.count(ch.topic) == 0) || topics.count(ch.topic) != 0 || refused.count(ch.topic) != 0) continue;
      const auto sit = r->schemas().find(ch.schema_id);
      const std::string schema_name = sit != r->schemas().end() ? sit->second.name : "";
      const dds::RegisteredType* type = dds::find_type_by_schema(schema_name);
      std::string why;
      if (ch.message_encoding != "cdr") why = "message encoding '" + ch.message_encoding + "', not cdr";
      else if (sit == r->schemas().end()) why = "no schema " + std::to_string(ch.schema_id) + " in the file";
      else if (type == nullptr) why = "type " + schema_name + " is not known to the rig";
      else if (sit->second.encoding == "ros2msg") why = schema_difference(schema_name, sit->second.data, type->schema);
      if (!why.empty()) {
        refused[ch.topic] = why;
        std::fprintf(stderr, "rig play: %s: refused: %s\n", ch.topic.c_str(), why.c_str());
        continue;
      }
      dds::QosSpec q;
      q.depth = 10;
      if (const auto m = ch.metadata.find("offered_qos_profiles"); m != ch.metadata.end()) {
        const auto parsed = parse_offered_qos_profiles(m->second);
        if (parsed.ok) q = parsed.qos;
      }
      topics[ch.topic].writer = std::make_unique<dds::RawWriter>(participant, dds::ros_to_dds_topic(ch.topic), *type, q);
    }
    readers.push_back(std::move(r));
  }
  if (topics.empty()) {
    std::fprintf(stderr, "rig play: %s: nothing to play\n", o.path.c_str());
    return 1;
  }
  // A reader thread decompresses and copies the messages ahead (up to kAheadBytes) so that chunk
  // decompression, CRC and page faults stay off the timed path; this thread only sleeps and writes.
  constexpr std::size_t kAheadBytes = 256u << 20;
  std::mutex mu;
  std::condition_variable cv;
  std::deque<Pending> ahead;
  std::size_t ahead_bytes = 0;
  bool done = false;
  std::atomic<bool> stop{false};
  std::thread reader([&] {
    const auto push = [&](Pending&& p) {
      std::unique_lock lock(mu);
      cv.wait(lock, [&] { return ahead_bytes < kAheadBytes || stop; });
      ahead_bytes += p.data.size();
      ahead.push_back(std::move(p));
      cv.notify_all();
    };
    bool any = false;
    do {
      push(Pending{});  // a new pass: the timing restarts
      std::uint64_t first_log = 0;
      const std::uint64_t skip = static_cast<std::uint64_t>(o.start_s * 1e9);
      for (auto& r : readers) {
        if (stop) break;
        r->for_each_message([&](const record::McapMessage& m) {
          if (stop) return false;
          const auto ch = r->channels().find(m.channel_id);
          if (ch == r->channels().end()) return true;
          const auto t = topics.find(ch->second.topic);
          if (t == topics.end()) return true;
          if (first_log == 0) first_log = m.log_time;
          if (m.log_time < first_log + skip) return true;
          any = true;
          push(Pending{&t->second, m.log_time, std::vector<std::byte>(m.data.begin(), m.data.end())});
          return true;
        });
      }
    } while (o.loop && !stop && any);
    std::lock_guard lock(mu);
    done = true;
    cv.notify_all();
  });
  if (o.rt_priority > 0) {
    if (const auto r = try_realtime_priority(o.rt_priority); !r)
      std::fprintf(stderr, "rig play: SCHED_FIFO %d refused (%s): normal scheduling\n", o.rt_priority, r.why_not.c_str());
  }
  wait_for_shutdown(static_cast<int>(o.delay_s * 1000));

  std::vector<double> late_ms;
  std::uint64_t played = 0;
  bool have_base = false;
  std::uint64_t base_log = 0;
  Nanos t0 = 0;
  while (!shutdown_requested()) {
    Pending p;
    {
      std::unique_lock lock(mu);
      cv.wait_for(lock, std::chrono::milliseconds(100), [&] { return !ahead.empty() || done; });
      if (ahead.empty()) {
        if (done) break;
        continue;
      }
      p = std::move(ahead.front());
      ahead.pop_front();
      ahead_bytes -= p.data.size();
      cv.notify_all();
    }
    if (p.topic == nullptr) {
      have_base = false;
      continue;
    }
    if (!have_base) {
      base_log = p.log_time;
      t0 = monotonic_now_ns();
      have_base = true;
    }
    const double offset = p.log_time >= base_log ? static_cast<double>(p.log_time - base_log) / o.rate : 0.0;
    const Nanos target = t0 + static_cast<Nanos>(offset);
    const timespec ts{static_cast<time_t>(target / 1'000'000'000), static_cast<long>(target % 1'000'000'000)};
    while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR && !shutdown_requested()) {
    }
    if (shutdown_requested()) break;
    late_ms.push_back(static_cast<double>(monotonic_now_ns() - target) / 1e6);
    if (p.topic->writer->write(p.data, vehicle_now_ns()).ok()) ++p.topic->played;
    else ++p.topic->write_errors;
    ++played;
  }
  {
    std::lock_guard lock(mu);
    stop = true;
    cv.notify_all();
  }
  reader.join();

  for (const auto& r : readers)
    for (const auto& p : r->problems()) {
      std::fprintf(stderr, "rig play: %s: offset %llu: %s\n", r->path().c_str(), static_cast<unsigned long long>(p.offset), p.what.c_str());
      problems.push_back({{"file", r->path()}, {"offset", p.offset}, {"what", p.what}});
    }
  std::sort(late_ms.begin(), late_ms.end());
  nlohmann::json j;
  j["played"] = played;
  for (const auto& [name, t] : topics) j["topics"][name] = {{"played", t.played}, {"write_errors", t.write_errors}};
  for (const auto& [name, why] : refused) j["refused"][name] = why;
  j["late_ms"] = {{"p50", nearest_rank_percentile(late_ms, 0.5)}, {"p99", nearest_rank_percentile(late_ms, 0.99)},
                  {"max", late_ms.empty() ? 0.0 : late_ms.back()}};
  j["problems"] = problems;
  std::printf("%s\n", j.dump().c_str());
  std::fflush(stdout);
  return problems.empty() ? 0 : 1;
}

void add_play(CLI::App& app, cli::Context& ctx) {
  auto* cmd = app.add_subcommand("play", "Publish a recording's topics again at its timing");
  auto o = std::make_shared<PlayOptions>();
  auto domain = std::make_shared<int>(0);
  cmd->add_option("PATH", o->path,
                  "NAME.mcap, or a split recording's folder (its files in metadata.yaml's order, then unlisted "
                  "FOLDER_N.mcap)")
      ->required()
      ->check(CLI::ExistingPath);
  cmd->add_option("--rate", o->rate, "Speed factor")->check(CLI::PositiveNumber)->capture_default_str();
  cmd->add_flag("--loop", o->loop, "Play again from the start at the end");
  cmd->add_option("--start", o->start_s, "Skip the first S seconds")->check(CLI::NonNegativeNumber);
  cmd->add_option("--topics", o->topics, "Only these ROS topics");
  cmd->add_option("--delay", o->delay_s, "Seconds between creating the writers and the first message (discovery)")
      ->check(CLI::NonNegativeNumber)->capture_default_str();
  cmd->add_option("--domain", *domain, "DDS domain id")->check(CLI::Range(0, 232));
  cmd->add_option("--rt-priority", o->rt_priority, "SCHED_FIFO priority of the timed writing thread (0: normal)")
      ->check(CLI::Range(0, 99));
  cmd->add_option("--dds-profile", o->dds.profile, "Cyclone XML profile (default: loopback)");
  cmd->add_option("--transport", o->dds.transport, "udp, or shm (a RouDi must run)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, dds::Transport>{{"udp", dds::Transport::kUdp},
                                                                                {"shm", dds::Transport::kShm}}));
  cmd->callback([&ctx, o, domain] {
    o->dds.domain_id = static_cast<dds_domainid_t>(*domain);
    try {
      ctx.exit_code = run_play(*o);
    } catch (const record::McapError& e) {
      std::fprintf(stderr, "rig play: %s\n", e.what());
      ctx.exit_code = cli::kRuntime;
    }
  });
}

}  // namespace sensor_rig::rig
