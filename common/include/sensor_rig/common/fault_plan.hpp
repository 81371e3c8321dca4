#pragma once
// One fault vocabulary for every mock device (docs/faults.md). `rig chaos --faults`, `rig lidar
// replay --fault`, the camera fakes and `rig mock paravan` read the same specs and the same plan
// files, so a campaign names a fault once and every mock understands it.
//
//   SPEC := KIND [':' NAME '=' VALUE]... ['@' START_S] ['+' DURATION_S] ['~' EVERY_S] ['>' DEVICE]
//   KIND := CLASS '.' NAME   e.g. lidar.reorder, camera.never_answers, dbw.bad_crc, host.cpu_hog
//
// START is seconds after the device (or campaign) starts, DURATION how long the fault lasts (the
// kind's default when absent; 0 = one unit), EVERY a repeat period, DEVICE one device by its config
// name (default: every device of the class). Pure: no clock, no I/O but the plan file helpers.
#include <cstdint>
#include <map>
#include <random>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::faults {

enum class DeviceClass { kLidar, kCamera, kV4l2, kDbw, kHost };
std::string_view to_string(DeviceClass c) noexcept;

// A kind of the vocabulary: its name, device class, parameters with defaults ("n=1,ms=0"), default
// duration, what it does (for --help and docs/faults.md), and the ranges a random campaign draws its
// parameters and duration from:
//   DRAWS := ITEM [',' ITEM]...     ITEM := NAME '=' ALT ['|' ALT]...  |  '+' RANGE
//   ALT   := VALUE | RANGE          RANGE := LO '..' HI
// An alternative is picked with equal weight (repeat one to weigh it), a range uniformly (whole
// numbers when both ends are); '+' is the duration's range in seconds (any number within it). A
// parameter with no draw keeps its default. "n=1..12,ms=0|0|2..30": n from 1 to 12; ms 0 two times
// in three, else 2-30.
struct KindInfo {
  std::string_view name;
  DeviceClass device_class;
  std::string_view params;
  double default_duration_s;
  std::string_view what;
  std::string_view draws;
};
std::span<const KindInfo> kinds();
const KindInfo* find_kind(std::string_view name) noexcept;  // nullptr when unknown
// A parameter's choice as the parser checks it and the mocks read it: the same word in any case.
bool same_choice(std::string_view a, std::string_view b) noexcept;

struct FaultSpec {
  std::string kind;
  std::map<std::string, std::string> params;  // as given, defaults filled in by parse_spec
  double start_s = 0.0;
  double duration_s = 0.0;
  double every_s = 0.0;  // 0 = once
  std::string device;    // empty = every device of the kind's class
};

// Throws std::invalid_argument naming the part that is wrong (unknown kind, parameter the kind does
// not take, value that is not a number, negative time).
FaultSpec parse_spec(std::string_view spec);
std::string to_string(const FaultSpec& s);

// One occurrence of a fault on one device, times relative to the plan's epoch.
struct FaultEvent {
  std::uint64_t id = 0;  // unique in the plan; truth records name it
  std::string kind;
  std::string device;
  double at_s = 0.0;
  double duration_s = 0.0;
  std::map<std::string, std::string> params;

  [[nodiscard]] double number(const std::string& name, double fallback = 0.0) const;
  [[nodiscard]] std::string text(const std::string& name, const std::string& fallback = {}) const;
  [[nodiscard]] DeviceClass device_class() const;
  [[nodiscard]] bool active_at(double t_s) const noexcept {
    return t_s >= at_s && t_s < at_s + (duration_s > 0 ? duration_s : 1e-9);
  }
};

// A device's name and class, for expanding specs that name a class, and for random campaigns.
struct Device {
  std::string name;
  DeviceClass device_class;
  bool own_process = false;  // its mock is a process host.kill_mock / host.stall_mock can signal
};

// Every occurrence of the specs within [0, horizon_s), for the devices given (a spec without a
// device goes to every device of its class), sorted by time.
std::vector<FaultEvent> expand(std::span<const FaultSpec> specs, std::span<const Device> devices, double horizon_s);

// A random campaign: `rate_per_min` faults per minute on average (Poisson), each of a kind from
// `allowed` (empty: every kind a device here can take) on a device of its class, its parameters and
// duration drawn from the kind's `draws` (a duration at most a quarter of the horizon, or the kind's
// default if that is longer), or the kind's defaults when `draw_params` is false. Every allowed kind
// occurs at least once when the horizon leaves room for it. Same seed, same plan.
std::vector<FaultEvent> random_campaign(std::span<const std::string> allowed, std::span<const Device> devices,
                                        double rate_per_min, double horizon_s, std::uint64_t seed,
                                        bool draw_params = true);

// One draw of a kind's parameters and duration from its `draws` (the defaults where it draws none).
// Throws std::invalid_argument when the kind's draws do not parse (a test holds every kind's).
struct Drawn {
  std::map<std::string, std::string> params;
  double duration_s = 0.0;
};
Drawn draw(const KindInfo& kind, std::mt19937_64& rng);

// Plan files: JSON Lines. First line {"fault_plan":1,"epoch_mono_ns":N}: CLOCK_MONOTONIC at t = 0
// (every process of the rig on one host shares it, and it does not step with CLOCK_REALTIME); then one
// event per line {"id":..,"kind":..,"device":..,"at_s":..,"duration_s":..,"params":{..}}.
struct Plan {
  Nanos epoch_mono_ns = 0;
  std::vector<FaultEvent> events;

  // The events of one device (and those of the host, which every process sees).
  [[nodiscard]] std::vector<FaultEvent> for_device(const std::string& device) const;
};
void write_plan(const std::string& path, const Plan& plan);  // throws std::runtime_error
Plan read_plan(const std::string& path);                      // throws std::runtime_error naming file:line

// Under `rig chaos`, RIG_CHAOS_DIR names the campaign's folder: the plan at DIR/plan.jsonl, every mock's
// truth record at DIR/truth/DEVICE.jsonl. Empty strings when the variable is not set (no campaign).
std::string chaos_plan_path();
std::string chaos_truth_path(const std::string& device);

}  // namespace sensor_rig::faults
