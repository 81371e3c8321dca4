#pragma once
// The iceoryx daemon (RouDi) Cyclone's shared-memory transport needs: one per machine (fixed shm
// and socket names). RouDi starts one when none runs and stops it afterwards, removing what it
// left; when one already runs and answers, it is used as is ("external"), and a RouDi that does not
// answer is an error, never killed (it is not ours). Used by `rig up` and `rig perf`.
#include <sys/types.h>

#include <memory>
#include <string>

namespace sensor_rig {
class ChildProcess;
}

namespace sensor_rig::dds {

// Whether a RouDi serves this machine: a live, not stopped iox-roudi process bound to its socket
// (/tmp/roudi). Cheap (a /proc scan and one connect), no iceoryx runtime involved.
struct RouDiProbe {
  pid_t pid = 0;        // an iox-roudi process, 0 when none
  bool answers = false;  // ... that is running and bound to the RouDi socket
  std::string problem;  // why not, in words, when pid != 0 && !answers
};
RouDiProbe probe_roudi();

class RouDi {
 public:
  // Starts iox-roudi with `config_file` (empty: iceoryx's built-in pools), logging to `log_file`,
  // and waits until it is ready. When one already answers: uses it (external() true), or throws
  // when `allow_external` is false. Throws std::runtime_error with the reason otherwise, also when
  // `log_file` exists and is not a regular file (it is replaced: readiness is read from it).
  RouDi(const std::string& config_file, const std::string& log_file, bool allow_external = true);
  ~RouDi();  // stops the RouDi it started and removes its leftovers
  RouDi(const RouDi&) = delete;
  RouDi& operator=(const RouDi&) = delete;

  [[nodiscard]] bool external() const noexcept { return external_pid_ > 0; }
  [[nodiscard]] int pid() const noexcept { return pid_; }
  [[nodiscard]] double startup_s() const noexcept { return startup_s_; }
  // Ours: still running; external: still answers. Empty when alive, else what happened to it.
  [[nodiscard]] std::string check_alive();
  // Stops the RouDi it started (as the destructor does); afterwards its CPU seconds and peak RSS
  // (from wait4) are in stopped_cpu_s() / stopped_max_rss_kb(). No effect on an external RouDi.
  void stop();
  [[nodiscard]] double stopped_cpu_s() const noexcept { return stopped_cpu_s_; }
  [[nodiscard]] long stopped_max_rss_kb() const noexcept { return stopped_max_rss_kb_; }

 private:
  std::unique_ptr<ChildProcess> child_;
  int pid_ = 0;
  int external_pid_ = 0;
  double startup_s_ = 0.0;
  double stopped_cpu_s_ = 0.0;
  long stopped_max_rss_kb_ = 0;
};

// Files iceoryx 2.0 leaves when RouDi dies without cleaning up (management and payload segments,
// sockets, locks), removed only when no iox-roudi process runs; and the /tmp socket and lock of
// every participant's runtime whose process no longer runs (killed). Returns how many were there.
int remove_roudi_leftovers();

}  // namespace sensor_rig::dds
