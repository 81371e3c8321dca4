#pragma once
// `rig chaos CONFIG`: the rig on its mocks under a fault campaign, its output checked against the
// mocks' truth records (docs/faults.md). Runs `rig up CONFIG` and `rig monitor --record` as child
// processes with RIG_CHAOS_DIR set (every mock then writes its truth record and reads the plan),
// injects the host's faults itself, then hands everything to the judge (chaos_check.hpp).
#include <cstdint>
#include <string>
#include <vector>

#include "chaos_check.hpp"
#include "rig_config.hpp"

namespace sensor_rig::rig::chaos {

struct Options {
  std::string config;
  double duration_s = 60;
  std::uint64_t seed = 1;
  std::vector<std::string> faults;  // specs; without '@' a kind placed at random (seeded) times
  double rate_per_min = 10;
  bool default_params = false;  // random faults take the kinds' defaults, not draws from their ranges
  bool json = false;
  std::string out_dir;   // keep the campaign (plan, truth, monitor record, logs) here
  double warmup_s = 5;   // rig up and the monitor start, DDS discovers: no fault yet
  std::string judge_dir;  // judge a campaign kept with --out again, run nothing
};

// The kinds the mocks inject today (a plan may only name these: a fault no mock injects would
// prove nothing).
std::vector<std::string> injected_kinds();

// Why a config cannot run under chaos (a real device in it), or "".
std::string not_all_mocks(const RigConfig& cfg);
// The devices of a config as the fault vocabulary sees them, and what the judge expects of each topic.
std::vector<faults::Device> devices_of(const RigConfig& cfg);
std::map<std::string, TopicExpectation> expectations_of(const RigConfig& cfg);

// The plan for these options (seeded): timed specs exactly, untimed kinds at random times, or a
// random campaign of every injected kind, fitted to what each device's model can do. Throws
// std::invalid_argument for a bad or not injected spec.
std::vector<faults::FaultEvent> make_plan(const Options& o, const std::vector<faults::Device>& devices, const RigConfig& cfg);

// Exit code: 0 every invariant held, 1 one broken or the campaign failed, 2 bad usage / config (or,
// with judge_dir, a kept campaign that cannot be read).
int run(const Options& o);

}  // namespace sensor_rig::rig::chaos
