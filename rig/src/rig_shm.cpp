#include "rig_shm.hpp"

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <optional>

#include "rig_runner.hpp"
#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/shutdown.hpp"

#ifndef RIG_DEFAULT_SOURCE_DIR
#define RIG_DEFAULT_SOURCE_DIR "."
#endif

namespace sensor_rig::rig {

std::string rig_roudi_config(const RigConfig& cfg) {
  if (!cfg.roudi_config.empty()) return cfg.roudi_config;
  const char* src = std::getenv("RIG_SOURCE_DIR");
  return (std::filesystem::path(src != nullptr ? src : RIG_DEFAULT_SOURCE_DIR) / "config/iceoryx/rig-roudi.toml").string();
}

RigTransport::RigTransport(const RigConfig& cfg, const std::string& log_dir) {
  if (cfg.dds.transport != dds::Transport::kShm) return;
  const std::string config = rig_roudi_config(cfg);
  if (!std::filesystem::exists(config)) throw std::runtime_error("RouDi configuration not found: " + config);
  const std::string log = (std::filesystem::path(log_dir) / "roudi.log").string();
  roudi_ = std::make_unique<dds::RouDi>(config, log);
  if (roudi_->external()) {
    log::warn("rig", "shm: using the RouDi already running (iox-roudi pid " + std::to_string(roudi_->pid()) +
                         ", it answers); its mempools are its own, not " + config);
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
