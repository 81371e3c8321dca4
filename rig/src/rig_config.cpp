#include "rig_config.hpp"

#include <algorithm>
#include <filesystem>
#include <optional>
#include <set>
#include <sstream>

#include "rig_cameras.hpp"
#include "sensor_rig/common/config_node.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"

namespace sensor_rig::rig {

namespace {
// fusion: every LIDAR takes part, each with its pose in base_link (an error at the LIDAR's item).
void check_fusion(const config::Node& n, const std::vector<config::Node>& lidar_items, RigConfig& cfg) {
  cfg.fusion = drivers::parse_fusion_config(n);
  if (!cfg.fusion.enabled) return;
  if (cfg.lidars.empty()) n.fail("enable", "the fused cloud needs LIDARs (lidars: is empty)");
  if (cfg.lidars.size() > 255) n.fail("enable", "at most 255 LIDARs (a point's source id)");
  for (std::size_t i = 0; i < cfg.lidars.size() && i < lidar_items.size(); ++i)
    if (!cfg.lidars[i].extrinsics)
      lidar_items[i].fail("extrinsics", "fusion is enabled: give this LIDAR's pose in " + cfg.fusion.frame_id +
                                            " as extrinsics: {x, y, z, roll_deg, pitch_deg, yaw_deg}");
}

// rig.dds.shm: {subscribers, mempools: [{size, count}]} (roudi_pools.hpp). iceoryx refuses pools
// out of ascending order and chunk sizes that are not multiples of 8, at RouDi's start: here at the key.
std::optional<config::Node> parse_shm(const config::Node& dds_node, RigConfig& cfg) {
  auto shm = dds_node.child("shm");
  if (!shm) return shm;
  shm->allow_keys({"subscribers", "mempools"});
  if (cfg.dds.transport != dds::Transport::kShm) dds_node.fail("shm", "only used with transport: shm");
  cfg.shm_subscribers = static_cast<int>(shm->get_int("subscribers", 0, 64, cfg.shm_subscribers));
  const auto pools = shm->items("mempools");
  if (!pools.empty() && !cfg.roudi_config.empty())
    shm->fail("mempools", "give mempools or roudi_config (a whole RouDi file), not both");
  if (pools.size() > static_cast<std::size_t>(kMaxMempools))
    shm->fail("mempools", "at most " + std::to_string(kMaxMempools) + " pools (iceoryx)");
  std::uint64_t last = 0;
  for (const auto& p : pools) {
    p.allow_keys({"size", "count"});
    const Mempool m{static_cast<std::uint64_t>(p.get_int("size", 64, std::int64_t{1} << 32)),
                    static_cast<std::uint64_t>(p.get_int("count", 1, 1'000'000))};
    if (m.size % 8 != 0) p.fail("size", "must be a multiple of 8 (iceoryx aligns chunks to 8 bytes)");
    if (m.size <= last)
      p.fail("size", "pool sizes must ascend (iceoryx refuses them otherwise): " + std::to_string(m.size) + " after " +
                         std::to_string(last));
    last = std::max(last, m.size);
    cfg.shm_mempools.push_back(m);
  }
  return shm;
}

// Explicit mempools must hold the rig's largest samples (else every such write fails at run time).
void check_shm_fits(const config::Node& shm, const RigConfig& cfg) {
  if (cfg.shm_mempools.empty()) return;
  std::uint64_t largest = 0;
  for (const auto& p : cfg.shm_mempools) largest = std::max(largest, p.size);
  for (const auto& t : shm_topic_loads(cfg, 0)) {
    if (t.max_sample_bytes + kChunkOverhead <= largest) continue;
    shm.fail("mempools", t.topic + " needs chunks of " + std::to_string(t.max_sample_bytes + kChunkOverhead) +
                             " B (a sample of up to " + std::to_string(t.max_sample_bytes) + " B); the largest pool is " +
                             std::to_string(largest) + " B");
    return;
  }
}
}  // namespace

RigConfig load_rig_config(const std::string& path) {
  auto problems = std::make_shared<config::Problems>();
  auto root = config::Node::load_file(path, problems);
  problems->throw_if_any();  // unreadable or not YAML: nothing more to say
  RigConfig cfg;
  cfg.file = path;
  if (!root.expect_map()) problems->throw_if_any();
  root.allow_keys({"rig", "lidars", "cameras", "dbw", "sync_sets", "fusion"});
  std::optional<config::Node> shm;
  if (auto rig = root.child("rig", true)) {
    rig->allow_keys({"name", "dds", "diagnostics_period_ms"});
    cfg.name = rig->get_string("name", "rig");
    cfg.diagnostics_period_ms = static_cast<int>(rig->get_int("diagnostics_period_ms", 100, 60000, 1000));
    if (auto d = rig->child("dds")) {
      d->allow_keys({"domain", "profile", "transport", "roudi_config", "shm", "realtime_priority"});
      cfg.dds.domain_id = static_cast<dds_domainid_t>(d->get_int("domain", 0, 232, 0));
      cfg.dds.profile = d->get_path("profile", "");
      if (!cfg.dds.profile.empty() && !std::filesystem::exists(cfg.dds.profile))
        d->fail("profile", "file not found: " + cfg.dds.profile);
      cfg.dds.transport = d->get_enum("transport", {{"udp", dds::Transport::kUdp}, {"shm", dds::Transport::kShm}}, dds::Transport::kUdp);
      // SCHED_FIFO for Cyclone's receive/delivery/event threads (dds/thread_scheduling.hpp); 0 = normal.
      cfg.dds.realtime_priority = static_cast<int>(d->get_int("realtime_priority", 0, 99, 0));
      cfg.roudi_config = d->get_path("roudi_config", "");
      if (!cfg.roudi_config.empty() && !std::filesystem::exists(cfg.roudi_config))
        d->fail("roudi_config", "file not found: " + cfg.roudi_config);
      if (!cfg.roudi_config.empty() && cfg.dds.transport != dds::Transport::kShm)
        d->fail("roudi_config", "only used with transport: shm");
      shm = parse_shm(*d, cfg);
    }
  }
  std::set<std::string> names;
  std::set<int> ports;
  for (const auto& item : root.items("lidars")) {
    auto l = drivers::parse_lidar_config(item);
    if (!l.name.empty() && !names.insert(l.name).second) item.fail("name", "duplicate device name '" + l.name + "'");
    if (!ports.insert(l.port).second) item.fail("port", "port " + std::to_string(l.port) + " used twice");
    // The second port is `imu_port` in an Ouster's config, `position_port` otherwise: name what the file says.
    const char* second_port_key = item.has("imu_port") ? "imu_port" : "position_port";
    if (l.position_port != 0 && !ports.insert(l.position_port).second)
      item.fail(second_port_key, "port " + std::to_string(l.position_port) + " used twice");
    cfg.lidars.push_back(std::move(l));
  }
  cfg.cameras = parse_cameras(root);
  // A LIDAR-triggered camera needs that LIDAR in this rig (its sweep drives the trigger).
  const auto camera_items = root.items("cameras");
  for (std::size_t i = 0; i < cfg.cameras.size() && i < camera_items.size(); ++i) {
    const auto& lt = cfg.cameras[i].lidar_trigger;
    if (!lt.enabled() || names.count(lt.lidar) != 0) continue;
    std::string known;
    for (const auto& l : cfg.lidars) known += (known.empty() ? "" : ", ") + l.name;
    if (auto t = camera_items[i].child("trigger"))
      t->fail("lidar", "no lidar named '" + lt.lidar + "' in lidars: (" + (known.empty() ? "none" : known) + ")");
  }
  if (auto d = root.child("dbw")) cfg.dbw = drivers::parse_dbw_config(*d);
  if (auto f = root.child("fusion")) check_fusion(*f, root.items("lidars"), cfg);
  cfg.sync_sets = parse_sync_sets(root, stamped_topics(cfg.lidars, cfg.cameras, cfg.dbw));
  if (shm) check_shm_fits(*shm, cfg);
  problems->throw_if_any();
  return cfg;
}

std::string describe_shm(const RigConfig& cfg) {
  if (!cfg.roudi_config.empty()) return "  shm: RouDi mempools from " + cfg.roudi_config + "\n";
  const auto pools = rig_mempools(cfg);
  std::ostringstream o;
  o << "  shm: RouDi mempools "
    << (cfg.shm_mempools.empty() ? "sized for " + std::to_string(cfg.shm_subscribers) + " subscribers per topic"
                                 : std::string("from rig.dds.shm.mempools"))
    << ":";
  for (const auto& p : pools) o << " " << p.size << " B x " << p.count;
  o << " (" << (mempools_bytes(pools) + 512 * 1024) / (1024 * 1024) << " MB of /dev/shm)\n";
  return o.str();
}

std::string describe(const RigConfig& cfg) {
  std::ostringstream o;
  o << "rig '" << cfg.name << "' (" << cfg.file << "), DDS domain " << cfg.dds.domain_id << ", profile "
    << (cfg.dds.profile.empty() ? std::string("default") : cfg.dds.profile) << ", transport "
    << dds::to_string(cfg.dds.transport)
    << (cfg.dds.realtime_priority > 0 ? ", Cyclone threads SCHED_FIFO " + std::to_string(cfg.dds.realtime_priority) : "")
    << "\n";
  if (cfg.dds.transport == dds::Transport::kShm) o << describe_shm(cfg);
  for (const auto& l : cfg.lidars) {
    o << "  lidar " << l.name << ": " << l.model
      << (l.source == drivers::LidarSource::kPacket ? " packet " + l.interface + " port " : " udp " + l.host + ":") << l.port
      << (l.position_port ? std::string(lidar::mock::is_ouster_model(l.model) ? " imu " : " position ") + std::to_string(l.position_port)
                          : std::string())
      << ", returns "
      << lidar::to_string(l.returns) << ", time " << timesync::to_string(l.time_source) << ", qos " << dds::to_string(l.qos) << " -> /sensors/lidar/"
      << l.name << "/points";
    if (l.mock.kind == LidarMockConfig::Kind::kSynthetic) {
      o << " [mock: synthetic " << l.mock.rpm << " rpm";
      if (l.mock.phase_deg) o << ", phase-locked " << *l.mock.phase_deg << " deg";
      o << "]";
    }
    // What a real sensor's scans are sized for (shared-memory pools): said, or the slowest speed.
    if (l.mock.kind != LidarMockConfig::Kind::kSynthetic && !lidar::mock::is_ouster_model(l.model))
      o << ", " << drivers::sizing_rpm(l) << " rpm" << (l.rpm > 0 ? "" : " (not said: sized for the slowest, `rpm:` to say)");
    if (l.mock.kind == LidarMockConfig::Kind::kReplay) o << " [mock: replay " << l.mock.pcap << "]";
    if (l.mock.kind == LidarMockConfig::Kind::kMcap) o << " [mock: mcap " << l.mock.file << " " << l.mock.topic << "]";
    o << "\n";
  }
  o << describe_cameras(cfg.cameras);
  o << describe_sync_sets(cfg.sync_sets);
  if (cfg.fusion.enabled) {
    const auto& f = cfg.fusion;
    o << "  fusion: " << cfg.lidars.size() << " lidars -> " << drivers::kFusedTopic << " in " << f.frame_id
      << ", crop box " << (f.crop_box.enabled ? "on" : "off") << ", voxel " << f.voxel_leaf_m << " m, timeout "
      << f.timeout_ms << " ms\n";
  }
  if (cfg.dbw.enabled) {
    o << "  dbw: bridge on " << (cfg.dbw.transport.empty() ? "unix:" + cfg.dbw.bus : cfg.dbw.transport)
      << ", protocol " << (cfg.dbw.protocol.empty() ? std::string("config/dbw/paravan_ref.yaml") : cfg.dbw.protocol)
      << " -> /vehicle/dbw/status, /vehicle/state";
    if (cfg.dbw.mock_ecu) o << " [mock ECU on " << cfg.dbw.bus << "]";
    if (cfg.dbw.command_source.enabled) o << " [command source " << cfg.dbw.command_source.rate_hz << " Hz]";
    if (cfg.dbw.security.enabled)
      o << " [DDS Security on /vehicle/dbw/cmd: " << cfg.dbw.security.dir << ", bridge '" << cfg.dbw.security.bridge_identity
        << "', command '" << cfg.dbw.security.command_identity << "']";
    o << "\n";
  }
  return o.str();
}

}  // namespace sensor_rig::rig
