#pragma once
// The iceoryx daemon (RouDi) Cyclone's shared-memory transport needs. One per machine (fixed shm
// names). The runner starts its own when none runs and stops it afterwards, removing the shm and lock
// files it left; when one already runs, the runner uses it and says so (its mempools may not fit).
#include <cstdint>
#include <memory>
#include <string>

namespace sensor_rig::bench::perf {

class Child;

// A RouDi config (TOML) with mempools for `size`-byte samples: `chunks` of them plus small pools.
std::string roudi_config(std::uint32_t size, int chunks);
// Chunks a run needs in the worst practical case: every writer's chunk in flight and a few queued
// per reader (readers take at once; iceoryx shares one chunk among all subscribers of a write).
int roudi_chunks_for(int publishers, int subscriptions);

class RouDi {
 public:
  // Starts iox-roudi with `config_file`, logging to `log_file`, and waits until it is ready.
  // When a RouDi is already running: uses it (external() true), or throws when `allow_external` is false.
  RouDi(const std::string& config_file, const std::string& log_file, bool allow_external = true);
  ~RouDi();  // stops the RouDi it started and removes its leftovers
  RouDi(const RouDi&) = delete;
  RouDi& operator=(const RouDi&) = delete;

  [[nodiscard]] bool external() const noexcept { return external_pid_ > 0; }
  [[nodiscard]] int pid() const noexcept;
  [[nodiscard]] double startup_s() const noexcept { return startup_s_; }
  // Stops the RouDi it started (as the destructor does); afterwards its CPU seconds and peak RSS
  // (from wait4) are in stopped_cpu_s() / stopped_max_rss_kb(). No effect on an external RouDi.
  void stop();
  [[nodiscard]] double stopped_cpu_s() const noexcept { return stopped_cpu_s_; }
  [[nodiscard]] long stopped_max_rss_kb() const noexcept { return stopped_max_rss_kb_; }

 private:
  std::unique_ptr<Child> child_;
  int external_pid_ = 0;
  double startup_s_ = 0.0;
  double stopped_cpu_s_ = 0.0;
  long stopped_max_rss_kb_ = 0;
};

}  // namespace sensor_rig::bench::perf
