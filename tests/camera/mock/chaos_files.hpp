#pragma once
// A test's campaign folder (/tmp/rig_camera_chaos_<pid>_<n>: removed at its end) and plan files
// whose epoch is now, for the camera fakes' fault and truth tests.
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <string>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/fault_plan.hpp"
#include "sensor_rig/common/truth_record.hpp"

namespace sensor_rig::camera::test {

class ChaosFolder {
 public:
  ChaosFolder() {
    static std::atomic<int> n{0};
    dir_ = "/tmp/rig_camera_chaos_" + std::to_string(::getpid()) + "_" + std::to_string(n++);
    std::filesystem::create_directories(dir_);
  }
  ~ChaosFolder() {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  ChaosFolder(const ChaosFolder&) = delete;
  ChaosFolder& operator=(const ChaosFolder&) = delete;

  // Writes a plan of these specs (each for `device`, epoch = now) and returns its path.
  std::string plan(const std::string& device, const std::vector<std::string>& specs, double horizon_s = 60) {
    std::vector<faults::FaultSpec> parsed;
    for (const auto& s : specs) parsed.push_back(faults::parse_spec(s + ">" + device));
    const faults::Device d{device, faults::find_kind(parsed.front().kind)->device_class};
    faults::Plan p;
    p.epoch_mono_ns = epoch_ = monotonic_now_ns();
    p.events = faults::expand(parsed, std::span<const faults::Device>(&d, 1), horizon_s);
    for (std::size_t i = 0; i < p.events.size(); ++i) p.events[i].id = i + 1;
    faults::write_plan(dir_ + "/plan.jsonl", p);
    return dir_ + "/plan.jsonl";
  }
  [[nodiscard]] std::string truth() const { return dir_ + "/truth.jsonl"; }
  [[nodiscard]] Nanos epoch() const { return epoch_; }  // the last plan's t = 0 (CLOCK_MONOTONIC)

 private:
  std::string dir_;
  Nanos epoch_ = 0;
};

inline std::size_t count_fate(const truth::Log& log, truth::Fate f) {
  std::size_t n = 0;
  for (const auto& p : log.parts) n += p.fate == f ? 1 : 0;
  return n;
}

}  // namespace sensor_rig::camera::test
