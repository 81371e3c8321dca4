#include "chaos_run.hpp"

#include <signal.h>
#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <deque>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <thread>

#include "chaos_campaign_files.hpp"
#include "chaos_diagnostics.hpp"
#include "chaos_host_faults.hpp"
#include "network_delay.hpp"
#include "sensor_rig/lidar/mock/packet_fields.hpp"
#include "sensor_rig/lidar/mock/scene.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/common/errors.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/dbw/bridge/defaults.hpp"
#include "sensor_rig/dbw/bridge/protocol.hpp"

namespace sensor_rig::rig::chaos {
namespace {

namespace fs = std::filesystem;
using faults::DeviceClass;

std::string camera_topic(const std::string& name) { return "/sensors/camera/" + name + "/image_raw"; }
std::string lidar_topic(const std::string& name) { return "/sensors/lidar/" + name + "/points"; }

bool injected(const std::string& kind) {
  const auto k = injected_kinds();
  return std::find(k.begin(), k.end(), kind) != k.end();
}

// The campaign's folder: --out DIR (kept), else a temporary one removed at the end.
class CampaignDir {
 public:
  explicit CampaignDir(const std::string& out) {
    if (!out.empty()) {
      path_ = out;
      fs::create_directories(path_);
      // A previous campaign's: none of it may be judged with this one's (judge.json last of all).
      for (const char* old : {"truth", "logs", "monitor.csv", "fused_sets.jsonl", "judge.json"}) fs::remove_all(path_ / old);
    } else {
      std::string tmpl = (fs::temp_directory_path() / ("rig-chaos-" + std::to_string(::getpid()) + "-XXXXXX")).string();
      if (::mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("cannot create a campaign directory");
      path_ = tmpl;
      owned_ = true;
    }
    fs::create_directories(path_ / "truth");
    fs::create_directories(path_ / "logs");
  }
  ~CampaignDir() {
    std::error_code ec;
    if (owned_) fs::remove_all(path_, ec);
  }
  CampaignDir(const CampaignDir&) = delete;
  CampaignDir& operator=(const CampaignDir&) = delete;
  [[nodiscard]] const fs::path& path() const { return path_; }

 private:
  fs::path path_;
  bool owned_ = false;
};

struct MonitorLine {
  Nanos mono_ns;  // when we read it (the monitor prints once a second)
  std::string text;
};

// The monitor's last --json line per topic (what it says at the end), and what the rig itself
// counted within the judged window: its cumulative `counted_lost` (units a driver knows never
// completed; issue 26's monitor publishes it) and `unheard` (a LIDAR's turns it heard nothing in) at
// the window's end minus at its start.
std::map<std::string, MonitorTotals> monitor_totals(const std::vector<MonitorLine>& lines, Nanos begin_mono, Nanos end_mono,
                                                    std::map<std::string, std::uint64_t>& counted_lost,
                                                    std::map<std::string, std::uint64_t>& unheard) {
  std::map<std::string, MonitorTotals> out;
  std::map<std::string, std::uint64_t> at_begin[2], at_end[2];
  std::map<std::string, std::uint64_t>* const within[2] = {&counted_lost, &unheard};
  for (const auto& line : lines) {
    const auto j = nlohmann::json::parse(line.text, nullptr, false);
    if (j.is_discarded() || !j.is_object() || !j.contains("topic")) continue;
    const std::string topic = j["topic"].get<std::string>();
    out[topic] = MonitorTotals{j.value("received", std::uint64_t{0}), j.value("lost", std::uint64_t{0})};
    for (int k = 0; k < 2; ++k) {
      const char* key = k == 0 ? "counted_lost" : "unheard";
      if (!j.contains(key)) continue;
      const auto n = j[key].get<std::uint64_t>();
      if (line.mono_ns <= begin_mono) at_begin[k][topic] = n;
      if (line.mono_ns <= end_mono) at_end[k][topic] = n;
    }
  }
  for (int k = 0; k < 2; ++k)
    for (const auto& [topic, n] : at_end[k]) (*within[k])[topic] = n - std::min(n, at_begin[k][topic]);
  return out;
}

std::string seconds_arg(double s) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f", s);
  return b;
}

// What a model can do: an Ouster's rotor runs at its lidar mode's rate (a change is a reconfiguration,
// not a fault), a Pandar40P at 600 or 1200 rpm only. A random rpm_change goes to a LIDAR that can
// turn at another speed, at a speed it can turn at; a corrupt field is one its packets have.
void fit_to_models(std::vector<faults::FaultEvent>& events, const RigConfig& cfg) {
  auto model_of = [&](const std::string& name) -> std::string {
    for (const auto& l : cfg.lidars)
      if (l.name == name) return l.model;
    return {};
  };
  auto can_change_rpm = [](const std::string& model) { return model.rfind("OS", 0) != 0; };
  std::string spare;  // a LIDAR that can change its rpm
  for (const auto& l : cfg.lidars)
    if (l.mock.kind == LidarMockConfig::Kind::kSynthetic && can_change_rpm(l.model) && spare.empty()) spare = l.name;
  for (auto& e : events) {
    if (e.kind != "lidar.rpm_change") continue;
    if (!can_change_rpm(model_of(e.device))) {
      if (spare.empty()) throw std::invalid_argument("lidar.rpm_change: no LIDAR here can turn at another speed");
      e.device = spare;
    }
    const std::string model = model_of(e.device);
    const int rpm = static_cast<int>(e.number("rpm", 300));
    int base = 600;
    for (const auto& l : cfg.lidars)
      if (l.name == e.device) base = l.mock.rpm;
    if (model.rfind("Pandar", 0) == 0 && rpm != 600 && rpm != 1200) e.params["rpm"] = base == 1200 ? "600" : "1200";
  }
  // lidar.corrupt of a field the model's packets lack (a VLP-32C has no UDP sequence, a Pandar40P no
  // frame id): the next field in the vocabulary's order that they have. The mock refuses such a plan
  // outright, and a drawn field=udp_seq left the front LIDAR's mock dead for the whole campaign
  // (seed 7 with drawn parameters: 1,028 of ~6,000 scans). The plan records the field used.
  std::map<std::string, std::unique_ptr<lidar::mock::SyntheticSensor>> sensors;
  for (auto& e : events) {
    if (e.kind != "lidar.corrupt") continue;
    const std::string model = model_of(e.device);
    if (model.empty()) continue;
    auto& sensor = sensors[model];
    if (!sensor) {
      lidar::mock::SyntheticOptions o;
      o.model = model;
      try {
        sensor = lidar::mock::make_synthetic_sensor(o, lidar::mock::Scene::standard());
      } catch (const std::exception&) {
        continue;  // the mock will say what is wrong with the model
      }
    }
    const lidar::mock::PacketFields fields(*sensor);
    const auto has = [&](lidar::mock::PacketField f) {
      try {
        (void)fields.locate(f);
        return true;
      } catch (const std::invalid_argument&) {
        return false;
      }
    };
    const auto drawn = lidar::mock::packet_field_from_name(e.text("field", "byte"));
    if (!drawn || has(*drawn)) continue;
    constexpr lidar::mock::PacketField kOrder[] = {lidar::mock::PacketField::kTime,         lidar::mock::PacketField::kAzimuth,
                                                   lidar::mock::PacketField::kFrameId,      lidar::mock::PacketField::kColumnStatus,
                                                   lidar::mock::PacketField::kUdpSeq,       lidar::mock::PacketField::kByte};
    std::size_t at = 0;
    while (kOrder[at] != *drawn) ++at;
    for (std::size_t k = 1; k <= std::size(kOrder); ++k) {
      const auto f = kOrder[(at + k) % std::size(kOrder)];
      if (has(f)) {
        e.params["field"] = std::string(lidar::mock::to_string(f));
        break;
      }
    }
  }
}

}  // namespace

std::vector<std::string> injected_kinds() {
  // Updated as the mocks learn each kind; `rig chaos --help` lists them.
  std::vector<std::string> kinds{"lidar.reorder",       "lidar.duplicate_late", "lidar.loss_burst", "lidar.corrupt",   "lidar.second_sensor",
          "lidar.restart",       "lidar.stuck_azimuth",  "lidar.rpm_change", "lidar.blind_sector",
          "camera.never_answers", "camera.slow_open",   "camera.dies",      "camera.ptp",      "camera.exposure_change",
          "camera.auto_exposure", "camera.packet_loss",   "camera.chunk_data", "camera.padded_rows",
          "v4l2.stamp_mode",     "v4l2.sequence_gap",    "v4l2.disconnect",
          "dbw.loss",            "dbw.bad_crc",          "dbw.stuck_counter", "dbw.override",  "dbw.ecu_fault",
          "dbw.bus_off",         "dbw.no_status",
          "host.cpu_hog",        "host.kill_mock",       "host.stall_mock",     "host.network_delay"};
  // Stepping the clock needs CAP_SYS_TIME: without it the kind is not offered.
  if (ClockStep::not_permitted().empty()) kinds.push_back("host.clock_step");
  return kinds;
}

std::string not_all_mocks(const RigConfig& cfg) {
  for (const auto& l : cfg.lidars)
    if (l.mock.kind == LidarMockConfig::Kind::kNone) return "lidar '" + l.name + "' is a real device (no mock:)";
  for (const auto& c : cfg.cameras)
    if (c.mock.kind == drivers::CameraMockConfig::Kind::kNone) return "camera '" + c.name + "' is a real device (no mock:)";
  if (cfg.dbw.enabled && !cfg.dbw.mock_ecu) return "dbw drives a real ECU (mock_ecu: false)";
  return {};
}

std::vector<faults::Device> devices_of(const RigConfig& cfg) {
  std::vector<faults::Device> d;
  for (const auto& l : cfg.lidars)
    if (l.mock.kind != LidarMockConfig::Kind::kNone) d.push_back({l.name, DeviceClass::kLidar, true});
  // The in-process Aravis fakes take no faults (camera/README.md); their truth is judged all the same.
  for (const auto& c : cfg.cameras)
    if (c.mock.kind == drivers::CameraMockConfig::Kind::kGige || c.mock.kind == drivers::CameraMockConfig::Kind::kV4l2Fake)
      d.push_back({c.name, c.source.backend == "v4l2" ? DeviceClass::kV4l2 : DeviceClass::kCamera, false});
  if (cfg.dbw.enabled && cfg.dbw.mock_ecu) d.push_back({"paravan", DeviceClass::kDbw, true});
  return d;
}

std::map<std::string, TopicExpectation> expectations_of(const RigConfig& cfg) {
  std::map<std::string, TopicExpectation> out;
  for (const auto& l : cfg.lidars) out[lidar_topic(l.name)] = {l.name, l.mock.rpm / 60.0, {}};
  for (const auto& c : cfg.cameras) {
    TopicExpectation e{c.name, c.source.frame_rate, {}};
    if (c.lidar_trigger.enabled()) e.depends_on.push_back(c.lidar_trigger.lidar);
    out[camera_topic(c.name)] = e;
  }
  // The fused cloud: one sweep per rotation of the fusion's period (its max_spread_ms, as the judge
  // takes it) while no fault touches a LIDAR (or the host); not the first LIDAR's rate, which read
  // "healthy 200 %" beside a front LIDAR at 300 rpm.
  if (cfg.fusion.enabled && !cfg.lidars.empty()) {
    double rate_hz = cfg.lidars.front().mock.rpm / 60.0;
    if (cfg.fusion.max_spread_ms > 0) rate_hz = 1000.0 / static_cast<double>(cfg.fusion.max_spread_ms);
    TopicExpectation e{"fusion", rate_hz, {}};
    for (const auto& l : cfg.lidars) e.depends_on.push_back(l.name);
    out[kFusedCloudTopic] = e;
  }
  // The mock ECU's feedback frames, one /vehicle/state sample each, at the protocol's period.
  if (cfg.dbw.enabled && cfg.dbw.mock_ecu) {
    double rate_hz = 0;  // unknown: its isolation is not judged (the other invariants are)
    try {
      const auto p = dbw::Protocol::load(cfg.dbw.protocol.empty() ? dbw::default_protocol_config() : cfg.dbw.protocol);
      if (p.timing().tx_period_ns > 0) rate_hz = 1e9 / static_cast<double>(p.timing().tx_period_ns);
    } catch (const std::exception& e) {
      log::warn("chaos", std::string("drive-by-wire protocol: ") + e.what() + "; /vehicle/state's rate is not judged");
    }
    out["/vehicle/state"] = {"paravan", rate_hz, {}};
  }
  return out;
}

std::vector<faults::FaultEvent> make_plan(const Options& o, const std::vector<faults::Device>& devices, const RigConfig& cfg) {
  // `--faults none`: the baseline, the rig and its truth with nothing injected.
  if (o.faults.size() == 1 && o.faults.front() == "none") return {};
  std::vector<faults::FaultSpec> timed;
  std::vector<std::string> kinds;
  std::map<std::string, faults::FaultSpec> given;  // untimed kinds given with parameters or a duration keep them
  for (const auto& item : o.faults) {
    // A list may also come as one argument separated by ';' or ','.
    std::string rest = item;
    for (char& c : rest)
      if (c == ';' || c == ',') c = '\n';
    std::size_t start = 0;
    while (start <= rest.size()) {
      const std::size_t nl = rest.find('\n', start);
      const std::string one = rest.substr(start, nl == std::string::npos ? std::string::npos : nl - start);
      start = nl == std::string::npos ? rest.size() + 1 : nl + 1;
      if (one.empty()) continue;
      const faults::FaultSpec s = faults::parse_spec(one);
      if (!injected(s.kind)) throw std::invalid_argument("'" + one + "': no mock injects " + s.kind + " yet");
      if (one.find('@') != std::string::npos || one.find('~') != std::string::npos) timed.push_back(s);
      else {
        kinds.push_back(s.kind);
        const std::string head = one.substr(0, one.find_first_of("@+~>"));
        if (head.find(':') != std::string::npos || one.find('+') != std::string::npos) given[s.kind] = s;
      }
    }
  }
  std::vector<faults::FaultEvent> events = faults::expand(timed, devices, o.duration_s);
  if (timed.empty() || !kinds.empty()) {
    const std::vector<std::string> pool = kinds.empty() ? injected_kinds() : kinds;
    auto random = faults::random_campaign(pool, devices, o.rate_per_min, o.duration_s, o.seed, !o.default_params);
    for (auto& e : random) {
      const auto it = given.find(e.kind);
      if (it == given.end()) continue;
      e.params = it->second.params;  // what was given, the kind's defaults for the rest
      e.duration_s = it->second.duration_s;
    }
    events.insert(events.end(), random.begin(), random.end());
  }
  fit_to_models(events, cfg);
  std::stable_sort(events.begin(), events.end(), [](const auto& a, const auto& b) { return a.at_s < b.at_s; });
  for (std::size_t i = 0; i < events.size(); ++i) events[i].id = i + 1;
  return events;
}

namespace {

// `rig chaos --judge DIR`: a kept campaign judged again, nothing run.
int judge_kept(const Options& o) {
  Input in;
  std::vector<std::string> campaign_errors;
  try {
    in = read_campaign(o.judge_dir, campaign_errors);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: rig chaos --judge: %s\n", e.what());
    return 2;
  }
  std::fprintf(stderr, "chaos: judging the campaign kept in %s again (%zu truth records, %zu samples, %zu faults planned)\n",
               o.judge_dir.c_str(), in.truths.size(), in.samples.size(), in.events.size());
  Result r = check(in);
  r.campaign_errors = campaign_errors;
  std::fputs(result_text(r).c_str(), stderr);
  if (o.json) std::printf("%s\n", result_json(r).c_str());
  return r.all_held() ? 0 : 1;
}

}  // namespace

int run(const Options& o) {
  if (!o.judge_dir.empty()) return judge_kept(o);
  if (o.config.empty()) {
    std::fprintf(stderr, "error: rig chaos needs a CONFIG (or --judge DIR)\n");
    return 2;
  }
  RigConfig cfg;
  try {
    cfg = load_rig_config(o.config);
  } catch (const ConfigError& err) {
    std::fprintf(stderr, "%s\n", err.what());
    return 2;
  }
  // Faults on a real car's devices are not this command's business: every device must be a mock.
  if (const std::string why = not_all_mocks(cfg); !why.empty()) {
    std::fprintf(stderr, "error: rig chaos runs the rig on its mocks: %s\n", why.c_str());
    return 2;
  }
  const auto devices = devices_of(cfg);
  for (const auto& c : cfg.cameras)
    if (c.mock.kind == drivers::CameraMockConfig::Kind::kAravisInProcess)
      std::fprintf(stderr, "chaos: camera '%s' (in-process Aravis fake) takes no faults: judged against its truth only\n", c.name.c_str());
  faults::Plan plan;
  try {
    plan.events = make_plan(o, devices, cfg);
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "error: --faults %s\n", e.what());
    return 2;
  }
  // A campaign killed while the clock was stepped left its step: undo it before anything else.
  for (const auto& line : ClockStep::sweep()) log::warn("chaos", line);
  // ... and a netem delay it left on lo.
  for (const auto& line : LoopbackDelay::sweep()) log::warn("chaos", line);
  // host.network_delay: netem on lo where the kernel has it (the host's event, device "lo", which no
  // mock takes), else the mocks hold their traffic (the event stays every process's): the LIDAR
  // mocks their datagrams, the GigE fakes their GVSP datagrams, the mock ECU its CAN frames.
  std::vector<int> lidar_ports;
  for (const auto& l : cfg.lidars)
    for (const int p : {l.port, l.position_port})
      if (p > 0) lidar_ports.push_back(p);
  if (std::any_of(plan.events.begin(), plan.events.end(), [](const auto& e) { return e.kind == "host.network_delay"; })) {
    const std::string why = LoopbackDelay::unavailable();
    for (auto& e : plan.events)
      if (e.kind == "host.network_delay" && why.empty()) e.device = "lo";
    std::fprintf(stderr, "chaos: host.network_delay %s\n",
                 why.empty() ? "by netem on lo (the LIDARs' UDP ports; the cameras' and the CAN bus's traffic is not held)"
                             : ("held in the mocks: LIDAR datagrams, GigE cameras' GVSP, the mock ECU's CAN frames (no netem on lo: " +
                                why + ")")
                                   .c_str());
  }
  CampaignDir dir(o.out_dir);
  const std::string exe = self_executable();
  // t = 0 of the plan: after the warm-up, on the clock every process shares and no step moves.
  const auto now = clock_pair_now();
  plan.epoch_mono_ns = now.monotonic_ns + static_cast<Nanos>(o.warmup_s * 1e9);
  const Nanos epoch_vehicle = now.vehicle_ns + static_cast<Nanos>(o.warmup_s * 1e9);
  faults::write_plan((dir.path() / "plan.jsonl").string(), plan);
  std::map<std::string, std::uint64_t> planned;
  for (const auto& e : plan.events) ++planned[e.kind];
  std::fprintf(stderr, "chaos: %zu faults planned over %.0f s (seed %llu) in %s\n", plan.events.size(), o.duration_s,
               static_cast<unsigned long long>(o.seed), dir.path().c_str());

  const std::vector<std::string> env{"RIG_CHAOS_DIR=" + dir.path().string(), "RIG_LOG_DIR=" + (dir.path() / "logs").string()};
  ChildOptions up_opt;
  up_opt.env = env;
  up_opt.log_file = (dir.path() / "logs" / "rig_up.log").string();
  ChildProcess up({exe, "up", o.config, "--duration", seconds_arg(o.warmup_s + o.duration_s + 1.5)}, up_opt);
  // The monitor watches the whole campaign and records every stamped sample.
  std::vector<std::string> mon_argv{exe, "monitor", "--json", "--record", (dir.path() / "monitor.csv").string(),
                                    "--duration", seconds_arg(o.warmup_s + o.duration_s), "--domain",
                                    std::to_string(cfg.dds.domain_id)};
  if (!cfg.dds.profile.empty()) mon_argv.insert(mon_argv.end(), {"--dds-profile", cfg.dds.profile});
  ChildOptions mon_opt;
  mon_opt.pipe_stdio = true;
  mon_opt.log_file = (dir.path() / "logs" / "monitor.log").string();
  ChildProcess monitor(mon_argv, mon_opt);
  DiagnosticsLog diagnostics(cfg.dds);  // when the rig said a topic's stamps were unsynchronized
  HostFaults host(plan.events, plan.epoch_mono_ns, (dir.path() / "truth" / "host.jsonl").string(), lidar_ports);
  host.start();

  std::vector<MonitorLine> monitor_lines;
  Nanos next_progress = monotonic_now_ns();
  while (monitor.running()) {
    for (auto& l : monitor.read_lines()) monitor_lines.push_back({monotonic_now_ns(), std::move(l)});
    if (shutdown_requested()) break;
    if (monotonic_now_ns() >= next_progress) {
      const double t = static_cast<double>(monotonic_now_ns() - plan.epoch_mono_ns) * 1e-9;
      const auto done = std::count_if(plan.events.begin(), plan.events.end(), [&](const auto& e) { return e.at_s <= t; });
      std::fprintf(stderr, "chaos: %s%.0f / %.0f s, %ld of %zu faults begun\n", t < 0 ? "warming up, " : "", std::max(0.0, t),
                   o.duration_s, static_cast<long>(done), plan.events.size());
      next_progress += 5'000'000'000;
    }
    ::usleep(100'000);
  }
  for (auto& l : monitor.read_lines()) monitor_lines.push_back({monotonic_now_ns(), std::move(l)});
  host.stop();
  {
    // The monitor's once-a-second lines as the judge read them (t_s: when, on the plan's clock), for
    // whoever checks a verdict on counted losses by hand.
    std::ofstream lines(dir.path() / "logs" / "monitor_lines.jsonl");
    for (const auto& l : monitor_lines)
      lines << nlohmann::json{{"t_s", static_cast<double>(l.mono_ns - plan.epoch_mono_ns) * 1e-9}, {"line", l.text}}.dump() << '\n';
  }
  if (shutdown_requested()) {
    std::fprintf(stderr, "chaos: interrupted, no verdict\n");
    return 1;
  }
  // A rig that does not stop, or ends badly, after a campaign is a finding too: said, and judged anyway.
  // Its log's last lines go to stderr with it: a campaign run by a test keeps no folder when it ends.
  const auto say_log_tail = [](const std::string& path) {
    std::ifstream log(path);
    std::deque<std::string> tail;
    for (std::string line; std::getline(log, line);) {
      tail.push_back(std::move(line));
      if (tail.size() > 20) tail.pop_front();
    }
    std::fprintf(stderr, "chaos: the last %zu lines of %s:\n", tail.size(), path.c_str());
    for (const auto& line : tail) std::fprintf(stderr, "  | %s\n", line.c_str());
  };
  std::vector<std::string> campaign_errors;
  if (!up.wait_exit(20'000)) {
    campaign_errors.push_back("rig up did not stop within 20 s of its --duration (killed; see " + up_opt.log_file + ")");
    up.stop();
  } else if (up.exit_status() != 0) {
    campaign_errors.push_back("rig up ended with status " + std::to_string(up.exit_status()) + " (see " + up_opt.log_file + ")");
    say_log_tail(up_opt.log_file);
  }
  if (monitor.exit_status() != 0) {
    campaign_errors.push_back("rig monitor ended with status " + std::to_string(monitor.exit_status()) + " (see " +
                              mon_opt.log_file + ")");
    say_log_tail(mon_opt.log_file);
  }
  Input in;
  try {
    in.truths = read_truths(dir.path() / "truth");
    in.samples = read_records((dir.path() / "monitor.csv").string());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "chaos: %s\n", e.what());
    return 1;
  }
  in.events = plan.events;
  in.epoch_vehicle_ns = epoch_vehicle;
  // Judged: units made from 0.5 s into the plan to 2.5 s before its end (the monitor decides a
  // sample lost 2 s after its stamps; the last ones are still in flight when it stops).
  constexpr Nanos kLead = 500'000'000;
  const Nanos window_ns = static_cast<Nanos>((o.duration_s - 2.5) * 1e9);
  in.window_begin_ns = epoch_vehicle + kLead;
  in.window_end_ns = epoch_vehicle + window_ns;
  in.monitor = monitor_totals(monitor_lines, plan.epoch_mono_ns + kLead, plan.epoch_mono_ns + window_ns, in.counted_lost, in.unheard);
  in.count_edge_ns = 1'000'000'000 + static_cast<Nanos>(cfg.diagnostics_period_ms) * 1'000'000;  // a line, a period
  in.expected = expectations_of(cfg);
  in.unsynchronized = diagnostics.unsynchronized();
  {  // why: one line per change of a flagged topic's message, seconds from the campaign's epoch
    std::ofstream flags(dir.path() / "logs" / "flags.jsonl");
    for (const auto& f : diagnostics.flag_reasons())
      flags << nlohmann::json{{"at_s", static_cast<double>(f.stamp - epoch_vehicle) / 1e9}, {"topic", f.topic}, {"message", f.message}}.dump()
            << "\n";
  }
  if (cfg.dbw.enabled && cfg.dbw.mock_ecu) {
    in.dbw_bridge = diagnostics.messages("dbw/bridge");
    try {
      in.dbw_ecu_timeout_ns = dbw::Protocol::load(cfg.dbw.protocol.empty() ? dbw::default_protocol_config() : cfg.dbw.protocol).timing().ecu_timeout_ns;
    } catch (const std::exception&) {
      // Warned about by expectations_of: the watchdog is not judged.
    }
    in.dbw_gaps_unknown = diagnostics.counter_delta("dbw/vehicle_state", "gaps_unknown", plan.epoch_mono_ns + kLead,
                                                    plan.epoch_mono_ns + window_ns + 1'500'000'000);
    std::fprintf(stderr, "chaos: dbw/bridge: %zu status reports read (its ECU watchdog is judged by them)\n", in.dbw_bridge.size());
  }
  if (cfg.fusion.enabled) {
    in.fused.enabled = true;
    for (const auto& l : cfg.lidars) in.fused.lidar_topics.push_back(lidar_topic(l.name));
    in.fused.period_ns = static_cast<Nanos>(cfg.fusion.max_spread_ms) * 1'000'000;
    in.fused.sets = diagnostics.fused_sets();
    write_fused_sets((dir.path() / "fused_sets.jsonl").string(), in.fused.sets);
    // Scans the fusion node dropped: its counter from the last status before the window to the
    // first one a status period after it (a scan is counted when it comes, reported within a period).
    in.fused.scans_dropped =
        diagnostics.counter_delta("fusion", "scans_dropped", plan.epoch_mono_ns + kLead, plan.epoch_mono_ns + window_ns + 1'500'000'000);
  }
  // Kept with the campaign, so that `rig chaos --judge DIR` can judge it again.
  write_judge_input((dir.path() / "judge.json").string(), in, campaign_errors);
  Result r = check(in);
  r.campaign_errors = campaign_errors;
  std::fputs(result_text(r).c_str(), stderr);
  if (!o.out_dir.empty()) std::fprintf(stderr, "chaos: campaign kept in %s\n", o.out_dir.c_str());
  if (o.json) std::printf("%s\n", result_json(r).c_str());
  return r.all_held() ? 0 : 1;
}

}  // namespace sensor_rig::rig::chaos
