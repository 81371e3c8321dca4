#pragma once
// `rig up` with rig.dds.transport: shm. iceoryx 2.0's RouDi, when stopped, sends SIGTERM to every
// process still registered with it and waits for them (45 s, then SIGKILL), and Cyclone never
// unregisters a process. So RouDi is owned by a parent `rig up` that never touches DDS: it starts
// RouDi (or joins an answering one, and says so), runs the rig as its child (`rig up
// --roudi-supervised`), watches RouDi, and stops it only after the rig has exited.
#include <memory>
#include <string>

#include "rig_config.hpp"
#include "sensor_rig/dds/roudi.hpp"

namespace sensor_rig::rig {

class RigTransport {
 public:
  // udp: nothing to start. shm: starts or joins RouDi; throws std::runtime_error saying why not.
  // RouDi's log and configuration go to `log_dir` (roudi.log, roudi.toml).
  RigTransport(const RigConfig& cfg, const std::string& log_dir);
  ~RigTransport() { stop(); }
  RigTransport(const RigTransport&) = delete;
  RigTransport& operator=(const RigTransport&) = delete;
  // Empty while the transport is usable; else what happened to RouDi.
  [[nodiscard]] std::string check();
  void stop();  // stops a RouDi we started and removes what it left; idempotent

 private:
  std::unique_ptr<dds::RouDi> roudi_;
};

// The RouDi configuration a rig uses: rig.dds.roudi_config, else `runtime_dir`/roudi.toml written
// from rig_mempools(cfg) (roudi_pools.hpp). Throws when it cannot be written.
std::string rig_roudi_config(const RigConfig& cfg, const std::string& runtime_dir);

// The parent `rig up` for shm (see above). Returns the rig's exit code, or 1 when RouDi could not
// start or died while the rig ran (the rig is then stopped).
int run_shm_supervisor(const RigConfig& cfg, const std::string& config_path, double duration_s);

}  // namespace sensor_rig::rig
