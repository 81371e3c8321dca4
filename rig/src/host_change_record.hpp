#pragma once
// What a campaign changed on the host (a CLOCK_REALTIME step, a netem delay on lo), recorded under
// $RIG_STATE_DIR (default /run/sensor-rig) before the change is made and removed once it is undone.
// A campaign killed before it undid its change leaves the record, and the next campaign undoes the
// change (the owners' sweeps). One mechanism for every such change.
#include <filesystem>
#include <string>
#include <vector>

namespace sensor_rig::rig {

// Whether `pid` is a running process (not gone, not a zombie its parent has not reaped yet: a
// SIGKILLed campaign's pid stays a zombie until init reaps it).
bool process_running(long pid);

class HostChangeRecord {
 public:
  // Writes `content` to a new record named `kind`-PID-N. Throws std::runtime_error when it cannot.
  HostChangeRecord(const std::string& kind, const std::string& content);
  HostChangeRecord(const HostChangeRecord&) = delete;
  HostChangeRecord& operator=(const HostChangeRecord&) = delete;
  // Removes the record (and the state directory when it holds nothing else): the change is undone.
  void remove() noexcept;
  [[nodiscard]] const std::string& path() const noexcept { return path_; }

  // The records of `kind` whose campaign is gone (their changes are still on the host), each with
  // its content. The caller undoes each change and then calls remove_orphan.
  struct Orphan {
    std::filesystem::path path;
    long pid = 0;
    std::string content;
  };
  static std::vector<Orphan> orphans(const std::string& kind);
  static void remove_orphan(const Orphan& o) noexcept;

 private:
  std::string path_;
};

}  // namespace sensor_rig::rig
