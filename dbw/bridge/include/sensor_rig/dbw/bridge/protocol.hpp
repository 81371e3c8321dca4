#pragma once
// A drive-by-wire protocol = DBC + YAML mapping of roles to messages/signals (config/dbw/*.yaml).
// Loading validates everything against the DBC and throws ConfigError listing file:line problems.
// Shared by the bridge (tx: commands, rx: ECU status/feedback) and the mock ECU (the reverse).
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/can/frame.hpp"
#include "sensor_rig/dbw/dbc/database.hpp"
#include "sensor_rig/dbw/safety/e2e.hpp"
#include "sensor_rig/dbw/safety/limits.hpp"

namespace sensor_rig::dbw {

// One mapped message: its label in the mapping (e.g. "steering"), the roles it carries (a role may
// live in several messages, e.g. one enable bit per actuator), constants and its own E2E settings.
struct RoleMessage {
  std::string role;  // the mapping's label of the message, e.g. "steering"
  const dbc::Message* message = nullptr;
  std::map<std::string, const dbc::Signal*, std::less<>> signals;  // role -> signal
  std::map<std::string, double, std::less<>> scales;               // role -> bus units per role unit (default 1)
  std::vector<std::pair<const dbc::Signal*, double>> constants;    // written into every frame
  safety::E2eConfig e2e;  // profile none when the message has no counter/CRC
  [[nodiscard]] const dbc::Signal* signal(std::string_view name) const noexcept;
  [[nodiscard]] double scale(std::string_view name) const noexcept {
    const auto it = scales.find(name);
    return it == scales.end() ? 1.0 : it->second;
  }
  [[nodiscard]] bool matches(const can::Frame& f) const noexcept;
};

struct ProtocolTiming {
  Nanos command_timeout_ns = 100'000'000;
  Nanos ecu_timeout_ns = 100'000'000;
  Nanos tx_period_ns = 10'000'000;
};

class Protocol {
 public:
  // Throws ConfigError (every problem with file:line) on a bad mapping or DBC.
  static Protocol load(const std::string& yaml_path);

  [[nodiscard]] const dbc::Database& db() const noexcept { return *db_; }
  // The vehicle's constexpr table with the mapping's `limits:` overrides applied.
  [[nodiscard]] const safety::VehicleLimits& limits() const noexcept { return limits_; }
  [[nodiscard]] const ProtocolTiming& timing() const noexcept { return timing_; }
  [[nodiscard]] int e2e_tolerance() const noexcept { return e2e_tolerance_; }
  // FNV-1a 64 over the DBC bytes and the mapping bytes, hex: identifies what ran.
  [[nodiscard]] const std::string& config_hash() const noexcept { return hash_; }
  [[nodiscard]] const std::string& mapping_path() const noexcept { return mapping_path_; }

  [[nodiscard]] const RoleMessage* tx(std::string_view role) const noexcept;
  [[nodiscard]] const RoleMessage* rx(std::string_view role) const noexcept;
  [[nodiscard]] const std::vector<RoleMessage>& tx_messages() const noexcept { return tx_; }
  [[nodiscard]] const std::vector<RoleMessage>& rx_messages() const noexcept { return rx_; }

  // Builds a frame of `rm` from role values (missing roles = 0 raw). With `e2e`, counter and CRC are
  // applied. Returns false on a non-finite value; clamped values are counted in *clamped.
  bool encode(const RoleMessage& rm, std::initializer_list<std::pair<std::string_view, double>> values,
              safety::E2eSender* e2e, can::Frame& out, int* clamped = nullptr) const noexcept;
  // An empty frame of `rm` (id, length) holding its constants; false if one does not fit.
  static bool start_frame(const RoleMessage& rm, can::Frame& out) noexcept;
  [[nodiscard]] static std::optional<double> value(const RoleMessage& rm, std::string_view role,
                                                   const can::Frame& f) noexcept;

 private:
  std::shared_ptr<const dbc::Database> db_;
  safety::VehicleLimits limits_ = safety::kParavanRef;
  ProtocolTiming timing_;
  int e2e_tolerance_ = 3;
  std::string hash_;
  std::string mapping_path_;
  std::vector<RoleMessage> tx_;
  std::vector<RoleMessage> rx_;
};

[[nodiscard]] std::string fnv1a64_hex(std::string_view a, std::string_view b);

}  // namespace sensor_rig::dbw
