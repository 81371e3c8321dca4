#include "rig_runner.hpp"

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>

#include "host_time_node.hpp"
#include "mock_faults.hpp"
#include "rig_cameras.hpp"
#include "sync_set_node.hpp"
#include "sensor_rig/dds/diagnostics.hpp"
#include "sensor_rig/drivers/dbw/dds_types.hpp"
#include "sensor_rig/drivers/fusion/fusion_node.hpp"
#include "sensor_rig/drivers/lidar/lidar_driver.hpp"
#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/common/fault_plan.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/loopback_address.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "sensor_rig/lidar/mock/synthetic_ouster.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"

namespace sensor_rig::rig {

// The device name the fault vocabulary gives the drive-by-wire mock ECU.
constexpr const char* kMockEcuDevice = "paravan";

std::vector<std::string> lidar_mock_command(const std::string& rig_exe, const LidarConfig& l) {
  std::vector<std::string> argv;
  if (l.mock.kind == LidarMockConfig::Kind::kNone) return argv;
  argv = {rig_exe, "lidar", "replay", "--to", l.host + ":" + std::to_string(l.port)};
  if (l.mock.kind == LidarMockConfig::Kind::kReplay) {
    argv.insert(argv.end(), {"--pcap", l.mock.pcap, "--rate", std::to_string(l.mock.rate)});
    if (l.mock.loop) argv.emplace_back("--loop");
  } else if (l.mock.kind == LidarMockConfig::Kind::kMcap) {
    // The recorded packets to the driver's ports; the second port's (position / IMU) with them.
    argv.insert(argv.end(), {"--mcap", l.mock.file, "--mcap-topic", l.mock.topic, "--rate", std::to_string(l.mock.rate),
                             "--delay", std::to_string(l.mock.delay_s)});
    if (l.mock.loop) argv.emplace_back("--loop");
  } else {
    argv.insert(argv.end(), {"--synthetic", l.model, "--rpm", std::to_string(l.mock.rpm)});
    if (l.mock.phase_deg) argv.insert(argv.end(), {"--phase-lock", std::to_string(*l.mock.phase_deg)});
    // The mock renders the sensor the driver decodes: same calibration, same Ouster metadata.
    if (!l.calibration.empty()) argv.insert(argv.end(), {"--calibration", l.calibration});
    if (!l.metadata.empty() && lidar::mock::is_ouster_model(l.model)) argv.insert(argv.end(), {"--metadata", l.metadata});
    // Same return mode as the driver expects (an Ouster's echoes come from its UDP profile instead).
    if (!lidar::mock::is_ouster_model(l.model)) argv.insert(argv.end(), {"--return", lidar::to_string(l.returns)});
  }
  // Position packets (GPRMC, PPS): the synthetic Velodyne's, or a capture's (port 8308 records).
  if (l.position_port != 0) argv.insert(argv.end(), {"--position-port", std::to_string(l.position_port)});
  if (l.mock.drop_rate > 0) argv.insert(argv.end(), {"--drop-rate", std::to_string(l.mock.drop_rate)});
  if (l.mock.corrupt_rate > 0) argv.insert(argv.end(), {"--corrupt-rate", std::to_string(l.mock.corrupt_rate)});
  // Under rig chaos: this LIDAR's faults of the campaign's plan, and its truth record in DIR/truth/.
  if (const std::string plan = faults::chaos_plan_path(); !plan.empty()) {
    const std::string truth = faults::chaos_truth_path(l.name);
    std::error_code ec;  // the mock creates it too; rig chaos has made it already
    std::filesystem::create_directories(std::filesystem::path(truth).parent_path(), ec);
    argv.insert(argv.end(), {"--device", l.name, "--truth", truth, "--fault-plan", plan});
  }
  return argv;
}

std::vector<std::vector<std::string>> dbw_commands(const std::string& rig_exe, const DbwConfig& d, int domain) {
  std::vector<std::vector<std::string>> out;
  if (!d.enabled) return out;
  const std::vector<std::string> dds_args =
      domain >= 0 ? std::vector<std::string>{"--domain", std::to_string(domain)} : std::vector<std::string>{};
  if (d.mock_ecu) {
    std::vector<std::string> ecu{rig_exe, "mock", "paravan", "--transport", "unix-listen:" + d.bus};
    if (!d.protocol.empty()) ecu.insert(ecu.end(), {"--config", d.protocol});
    for (const auto& f : d.mock_faults) ecu.insert(ecu.end(), {"--fault", f});
    out.push_back(ecu);
  }
  std::vector<std::string> bridge{rig_exe, "dbw", "bridge", "--transport",
                                  d.transport.empty() ? "unix:" + d.bus : d.transport};
  if (!d.protocol.empty()) bridge.insert(bridge.end(), {"--config", d.protocol});
  bridge.insert(bridge.end(), dds_args.begin(), dds_args.end());
  const auto bridge_security = drivers::security_args(d, true);  // dbw.security: DDS Security identities
  bridge.insert(bridge.end(), bridge_security.begin(), bridge_security.end());
  out.push_back(bridge);
  if (d.command_source.enabled) {
    const auto& c = d.command_source;
    out.push_back({rig_exe, "dbw", "send", "--enable", "--steer", std::to_string(c.steer_rad), "--throttle",
                   std::to_string(c.throttle), "--brake", std::to_string(c.brake), "--gear", std::to_string(c.gear),
                   "--rate", std::to_string(c.rate_hz), "--duration", "86400"});
    out.back().insert(out.back().end(), dds_args.begin(), dds_args.end());
    const auto send_security = drivers::security_args(d, false);
    out.back().insert(out.back().end(), send_security.begin(), send_security.end());
  }
  return out;
}

namespace {
// Bounded wait until a started dbw process is ready for the next one: the mock ECU's bus socket
// exists (the bridge can connect), the bridge's status writer is discovered (its DDS side is up,
// so the command source's first samples, the enable edge, are not lost).
bool wait_dbw_ready(const std::vector<std::string>& argv, const DbwConfig& d, const dds::Reader<msg::DbwStatus>& status) {
  if (argv.size() > 2 && argv[1] == "mock") {
    for (int i = 0; i < 500 && !std::filesystem::exists(d.bus); ++i) ::usleep(10'000);
    return std::filesystem::exists(d.bus);
  }
  if (argv.size() > 2 && argv[1] == "dbw" && argv[2] == "bridge") return status.wait_for_writers(1, 5000);
  return true;
}
}  // namespace

SyntheticMetadataDir::SyntheticMetadataDir() {
  if (const char* d = std::getenv("RIG_LOG_DIR"); d != nullptr && *d != '\0') {
    path_ = d;
    std::filesystem::create_directories(path_);
    return;
  }
  // Named after this process: a rig killed before its destructor ran leaves its folder, which the
  // next rig removes (its process no longer runs).
  const auto tmp = std::filesystem::temp_directory_path();
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(tmp, ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("rig-up-", 0) != 0) continue;
    const long pid = std::strtol(name.c_str() + 7, nullptr, 10);
    if (pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) std::filesystem::remove_all(e.path(), ec);
  }
  std::string tmpl = (tmp / ("rig-up-" + std::to_string(::getpid()) + "-XXXXXX")).string();
  if (::mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("cannot create a directory for synthetic metadata");
  path_ = tmpl;
  owned_ = true;
}

SyntheticMetadataDir::~SyntheticMetadataDir() {
  if (!owned_) return;
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

std::string SyntheticMetadataDir::write(const LidarConfig& l) const {
  const std::string json =
      lidar::mock::metadata_json(lidar::mock::synthetic_ouster_metadata(drivers::synthetic_mock_options(l)));  // validated on load
  const auto file = path_ / (l.name + "_synthetic_metadata.json");
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out << json;
  out.close();
  if (!out) throw std::runtime_error("cannot write " + file.string());
  return file.string();
}

bool needs_synthetic_metadata(const LidarConfig& l) {
  return l.mock.kind == LidarMockConfig::Kind::kSynthetic && l.metadata.empty() && lidar::mock::is_ouster_model(l.model);
}

int run_rig(const RigConfig& config, const RunOptions& opt) {
  // Addresses that a rig or test which ended without giving them back (SIGKILL, a crash) added to lo.
  for (const auto& a : LoopbackAddress::sweep())
    log::info("rig", "removed " + a + " from lo: added by a process that ended without removing it");
  // A synthetic Ouster without configured metadata: its mock's metadata, for both driver and mock.
  RigConfig cfg = config;
  if (const char* d = std::getenv("RIG_LOG_DIR"); d != nullptr && *d != '\0' && cfg.fusion.enabled) {
    std::error_code ec;
    std::filesystem::create_directories(d, ec);
    cfg.fusion.matcher_log = (std::filesystem::path(d) / "fusion_matcher.csv").string();
  }
  std::optional<SyntheticMetadataDir> metadata_dir;
  try {
    for (auto& l : cfg.lidars) {
      if (!needs_synthetic_metadata(l)) continue;
      if (!metadata_dir) metadata_dir.emplace();
      l.metadata = metadata_dir->write(l);
      log::info("rig", "lidar " + l.name + ": synthetic " + l.model + " metadata " + l.metadata);
    }
  } catch (const std::exception& e) {
    log::error("rig", e.what());
    return 1;
  }
  // Shared memory: the parent `rig up` runs RouDi (run_shm_supervisor); without one, stop here
  // (Participant says why) rather than let iceoryx wait 60 s and abort.
  dds::Participant participant(cfg.dds);
  log::info("rig", "'" + cfg.name + "' on DDS domain " + std::to_string(cfg.dds.domain_id) + ", profile " +
                       (participant.profile().empty() ? std::string("$CYCLONEDDS_URI") : participant.profile()) +
                       ", transport " + dds::to_string(cfg.dds.transport));
  dds::StampsWriter stamps(participant);
  dds::DiagnosticsPublisher diagnostics(participant);

  // Drivers first (sockets bound), then mocks: no packet of a mock is sent to a closed port.
  std::vector<std::unique_ptr<drivers::LidarDriver>> lidars;
  try {
    for (const auto& l : cfg.lidars) lidars.push_back(std::make_unique<drivers::LidarDriver>(l, participant, stamps));
  } catch (const std::exception& e) {
    log::error("rig", std::string("driver start failed: ") + e.what());
    return 1;
  }
  // The fused cloud takes each LIDAR node's scans in this process (no DDS round trip).
  std::unique_ptr<drivers::FusionNode> fusion;
  if (cfg.fusion.enabled) {
    try {
      fusion = std::make_unique<drivers::FusionNode>(cfg.fusion, cfg.lidars, participant, stamps);
    } catch (const std::exception& e) {
      log::error("rig", std::string("fusion start failed: ") + e.what());
      return 1;
    }
    for (std::size_t i = 0; i < lidars.size(); ++i) lidars[i]->add_scan_observer(fusion->input(i));
    fusion->start();
  }
  std::unique_ptr<CameraRig> cameras;
  try {
    cameras = std::make_unique<CameraRig>(cfg.cameras, participant, stamps);
  } catch (const std::exception& e) {
    log::error("rig", std::string("camera driver start failed: ") + e.what());
    return 1;
  }
  // LIDAR-triggered cameras learn the sweep from their LIDAR's driver (same process, no DDS).
  for (const auto& [lidar, observer] : cameras->sweep_observers())
    for (std::size_t i = 0; i < cfg.lidars.size(); ++i)
      if (cfg.lidars[i].name == lidar) lidars[i]->add_sweep_observer(observer);
  for (auto& d : lidars) d->start();
  cameras->start();  // GigE fakes first, then the nodes (which retry until their camera answers)
  SyncSetNode sync_sets(cfg.sync_sets, participant);  // /rig/stamps -> /rig/sets/<name>
  sync_sets.start();
  HostTimeNode host_time({.pmc = pmc_program()});  // rig/time: PTP state, realtime steps
  host_time.start();

  // Mock processes (and the dbw nodes): under `rig chaos` the host's faults kill or stop them, and
  // restart them, from another thread, so every access holds mocks_mutex.
  std::vector<MockProcess> mocks;
  std::mutex mocks_mutex;
  const std::string exe = self_executable();
  // The dbw processes take the rig's DDS domain as an argument; the bridge's status tells when it is up.
  const dds::Topic<msg::DbwStatus> dbw_status_topic(participant, drivers::kStatusTopic);
  const dds::Reader<msg::DbwStatus> dbw_status(participant, dbw_status_topic);
  for (const auto& argv : dbw_commands(exe, cfg.dbw, static_cast<int>(cfg.dds.domain_id))) {
    // The bridge is the only path to the actuators: its timeouts must not be scheduling delays.
    // Its participant takes the rig's DDS configuration (profile, shared memory) from CYCLONEDDS_URI.
    ChildOptions co;
    co.rt_priority = cfg.dbw.realtime_priority;
    co.env = {"CYCLONEDDS_URI=" + dds::cyclone_uri(cfg.dds)};
    const bool ecu = argv.size() > 2 && argv[1] == "mock";
    mocks.push_back(MockProcess{ecu ? std::string(kMockEcuDevice) : std::string{}, argv, co, ChildProcess(argv, co)});
    log::info("rig", "dbw: " + argv[1] + " " + argv[2] + ": pid " + std::to_string(mocks.back().child.pid()));
    // The ECU must listen before the bridge connects, the bridge subscribe before commands flow.
    if (!wait_dbw_ready(argv, cfg.dbw, dbw_status)) log::warn("rig", "dbw: " + argv[1] + " " + argv[2] + " not ready in time");
  }
  for (const auto& l : cfg.lidars) {
    auto argv = lidar_mock_command(exe, l);
    if (argv.empty()) continue;
    mocks.push_back(MockProcess{l.name, argv, ChildOptions{}, ChildProcess(argv, ChildOptions{})});
    log::info("rig", "mock for lidar " + l.name + ": pid " + std::to_string(mocks.back().child.pid()));
  }
  std::optional<MockFaults> mock_faults;
  if (const std::string plan = faults::chaos_plan_path(); !plan.empty()) {
    try {
      mock_faults.emplace(faults::read_plan(plan), mocks, mocks_mutex, faults::chaos_truth_path("host_mocks"));
    } catch (const std::exception& e) {
      log::error("rig", std::string("chaos: ") + e.what());
      return 1;
    }
  }

  const Nanos start = monotonic_now_ns();
  std::vector<bool> reported_dead(mocks.size(), false);
  while (!shutdown_requested()) {
    if (wait_for_shutdown(cfg.diagnostics_period_ms)) break;
    std::vector<dds::DriverStatus> statuses;
    statuses.reserve(lidars.size());
    for (const auto& d : lidars) statuses.push_back(d->status());
    if (fusion) statuses.push_back(fusion->status());
    cameras->supervise(statuses);
    sync_sets.supervise(statuses);
    host_time.supervise(statuses);
    {
      std::lock_guard lock(mocks_mutex);
      for (std::size_t i = 0; i < mocks.size(); ++i) {
        ChildProcess& c = mocks[i].child;
        if (c.running()) {
          reported_dead[i] = false;  // a restarted mock: its end is news again
        } else if (!reported_dead[i]) {
          reported_dead[i] = true;
          log::warn("rig", "mock '" + c.name() + "' exited with status " + std::to_string(c.exit_status()));
        }
      }
    }
    diagnostics.publish(statuses);
    if (opt.duration_s > 0 && static_cast<double>(monotonic_now_ns() - start) * 1e-9 >= opt.duration_s) break;
  }
  log::info("rig", "stopping");
  // Stop in reverse: the command source first, so the bridge sees silence and disengages.
  mock_faults.reset();  // no kill or restart from here on
  for (auto it = mocks.rbegin(); it != mocks.rend(); ++it) it->child.stop();
  host_time.stop();
  sync_sets.stop();
  cameras->stop();
  for (auto& d : lidars) d->stop();
  if (fusion) fusion->stop();  // after the LIDARs: they hand it their scans
  return 0;
}

}  // namespace sensor_rig::rig
