#include "rig_shm.hpp"

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include "rig_runner.hpp"
#include "roudi_pools.hpp"
#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/shutdown.hpp"

namespace sensor_rig::rig {

std::string rig_roudi_config(const RigConfig& cfg, const std::string& runtime_dir) {
  if (!cfg.roudi_config.empty()) return cfg.roudi_config;
  const auto pools = rig_mempools(cfg);
  const std::string path = (std::filesystem::path(runtime_dir) / "roudi.toml").string();
  std::ofstream out(path, std::ios::trunc);
  out << roudi_toml(pools, "Written by `rig up " + cfg.file + "` (rig/src/roudi_pools.hpp): " +
                               (cfg.shm_mempools.empty() ? "sized from its topics" : "rig.dds.shm.mempools") + ".");
  if (!out.flush()) throw std::runtime_error("cannot write the RouDi configuration " + path);
  return path;
}

namespace {
// A RouDi we join keeps its own pools: compare them with this rig's where its -c file (or
// iceoryx's built-in pools) says what they are.
void check_joined_roudi(const RigConfig& cfg, int pid) {
  const std::string file = roudi_config_file_of(pid);
  std::vector<Mempool> available;
  if (file.empty()) {
    available = iceoryx_default_mempools();
  } else {
    std::ifstream in(file);
    std::ostringstream text;
    text << in.rdbuf();
    available = parse_roudi_toml(text.str());
    if (!in || available.empty()) {
      log::warn("rig", "shm: cannot read the running RouDi's mempools from " + file +
                           ": whether this rig's samples fit is not checked");
      return;
    }
  }
  const std::string what = file.empty() ? std::string("its built-in pools") : file;
  if (const std::string short_of = mempools_shortfall(rig_mempools(cfg), available); !short_of.empty()) {
    log::warn("rig", "shm: the running RouDi (iox-roudi pid " + std::to_string(pid) + ", " + what +
                         ") is too small for this rig: " + short_of +
                         "; writes that find no chunk fail (counted per driver). Stop it and let rig up start its own");
  } else {
    log::info("rig", "shm: the running RouDi's mempools (" + what + ") hold this rig's samples");
  }
}
}  // namespace

RigTransport::RigTransport(const RigConfig& cfg, const std::string& log_dir) {
  if (cfg.dds.transport != dds::Transport::kShm) return;
  const std::string config = rig_roudi_config(cfg, log_dir);
  if (!std::filesystem::exists(config)) throw std::runtime_error("RouDi configuration not found: " + config);
  const std::string log = (std::filesystem::path(log_dir) / "roudi.log").string();
  roudi_ = std::make_unique<dds::RouDi>(config, log);
  if (roudi_->external()) {
    log::warn("rig", "shm: using the RouDi already running (iox-roudi pid " + std::to_string(roudi_->pid()) +
                         ", it answers); its mempools are its own, not " + config);
    check_joined_roudi(cfg, roudi_->pid());
  } else {
    log::info("rig", "shm: started iox-roudi pid " + std::to_string(roudi_->pid()) + " (" + config + ", ready in " +
                         std::to_string(roudi_->startup_s()).substr(0, 5) + " s, log " + log + ")");
  }
}

std::string RigTransport::check() { return roudi_ ? roudi_->check_alive() : std::string(); }

void RigTransport::stop() {
  if (!roudi_) return;
  const bool ours = !roudi_->external();
  roudi_.reset();  // stops ours and removes what it left
  if (ours) log::info("rig", "shm: iox-roudi stopped, its shared memory removed");
}

int run_shm_supervisor(const RigConfig& cfg, const std::string& config_path, double duration_s) {
  std::optional<SyntheticMetadataDir> log_dir;  // $RIG_LOG_DIR, else a temporary directory
  std::optional<RigTransport> transport;
  try {
    log_dir.emplace();
    transport.emplace(cfg, log_dir->path().string());
  } catch (const std::exception& e) {
    log::error("rig", std::string("shared memory transport: ") + e.what());
    return 1;
  }
  ChildProcess rig({self_executable(), "up", config_path, "--duration", std::to_string(duration_s), "--roudi-supervised"});
  int code = 0;
  for (;;) {
    if (!rig.running()) {
      code = rig.exit_status();
      break;
    }
    if (shutdown_requested()) {  // Ctrl-C reaches the rig too (same process group); SIGTERM only us
      code = rig.stop(15000);
      break;
    }
    if (const std::string lost = transport->check(); !lost.empty()) {
      // Without RouDi no endpoint can join, and a new RouDi would wipe the segments in use.
      log::error("rig", "shared memory transport lost: " + lost + "; stopping the rig");
      rig.stop(15000);
      code = 1;
      break;
    }
    wait_for_shutdown(100);
  }
  transport->stop();  // the rig and its processes are gone: RouDi has no client of ours to stop
  return code;
}

}  // namespace sensor_rig::rig
