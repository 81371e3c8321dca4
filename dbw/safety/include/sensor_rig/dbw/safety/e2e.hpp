#pragma once
// End-to-end protection of CAN payloads: rolling counters and CRCs on transmit, checked on receive.
// Named algorithms:
//   crc8_sae_j1850  CRC-8 poly 0x1D (AUTOSAR Crc_CalculateCRC8: init 0xFF, xor-out 0xFF; check 0x4B)
//   crc8h2f         CRC-8 poly 0x2F (AUTOSAR Crc_CalculateCRC8H2F: init 0xFF, xor-out 0xFF; check 0xDF)
//   p01             AUTOSAR E2E profile 1: J1850 CRC over Data ID (mode both/alt/low/nibble) + payload
//                   without the CRC byte, 4-bit counter 0..14
//   p02             AUTOSAR E2E profile 2: CRC8H2F over payload bytes 1.. + DataIDList[counter], counter 0..15
//   j1850           J1850 CRC over the payload without the CRC byte, then the Data ID low byte; counter 0..15
//   counter         counter only, 0..15
// Pure functions on byte spans; no allocation; status enums.
#include <array>
#include <cstdint>
#include <span>
#include <string_view>

namespace sensor_rig::dbw::safety {

// AUTOSAR Crc library semantics: `first` starts from the init value, otherwise continues from `start`
// (the previous call's result).
[[nodiscard]] std::uint8_t crc8_sae_j1850(std::span<const std::uint8_t> data, std::uint8_t start = 0xFF,
                                          bool first = true) noexcept;
[[nodiscard]] std::uint8_t crc8h2f(std::span<const std::uint8_t> data, std::uint8_t start = 0xFF,
                                   bool first = true) noexcept;

enum class E2eProfile : std::uint8_t { kNone, kCounter, kJ1850, kP01, kP02 };
enum class P01IdMode : std::uint8_t { kBoth, kAlt, kLow, kNibble };
[[nodiscard]] bool parse_profile(std::string_view name, E2eProfile& out) noexcept;
[[nodiscard]] std::string_view to_string(E2eProfile p) noexcept;
[[nodiscard]] bool parse_id_mode(std::string_view name, P01IdMode& out) noexcept;

struct E2eConfig {
  E2eProfile profile = E2eProfile::kNone;
  std::uint16_t data_id = 0;                    // p01, j1850
  P01IdMode id_mode = P01IdMode::kBoth;         // p01
  std::array<std::uint8_t, 16> data_id_list{};  // p02
  std::size_t crc_byte = 0;                     // byte holding the CRC (p02: 0)
  std::size_t counter_byte = 1;                 // byte holding the 4-bit counter
  bool counter_high_nibble = false;             // p01/p02 standard layout: low nibble of byte 1
  std::uint8_t max_delta = 1;                   // accepted counter jump (1 = no frame may be lost)
};

[[nodiscard]] std::uint8_t counter_modulus(E2eProfile p) noexcept;  // 15 for p01, 16 otherwise
[[nodiscard]] bool has_crc(E2eProfile p) noexcept;

// CRC of the payload as the profile defines it for `counter` (the CRC byte itself is skipped).
[[nodiscard]] std::uint8_t compute_crc(const E2eConfig& c, std::span<const std::uint8_t> data, std::uint8_t counter) noexcept;
[[nodiscard]] std::uint8_t read_counter(const E2eConfig& c, std::span<const std::uint8_t> data) noexcept;
// Writes counter (and the Data ID nibble for p01/nibble) then the CRC. False if the layout does not fit.
bool protect(const E2eConfig& c, std::span<std::uint8_t> data, std::uint8_t counter) noexcept;

enum class E2eStatus : std::uint8_t {
  kOk,             // CRC good, counter advanced by 1 (or first frame)
  kOkSomeLost,     // CRC good, counter advanced by 2..max_delta
  kRepeated,       // same counter as the previous frame (stuck counter)
  kWrongSequence,  // counter jumped further than max_delta
  kBadCrc,
  kBadLayout,  // frame too short for the configured positions, or p01 counter 15
};
[[nodiscard]] std::string_view to_string(E2eStatus s) noexcept;
[[nodiscard]] inline bool is_ok(E2eStatus s) noexcept { return s == E2eStatus::kOk || s == E2eStatus::kOkSomeLost; }

// Receiver state per protected message.
class E2eChecker {
 public:
  explicit E2eChecker(E2eConfig c) : c_(c) {}
  E2eStatus check(std::span<const std::uint8_t> data) noexcept;
  void reset() noexcept { synced_ = false; }
  [[nodiscard]] const E2eConfig& config() const noexcept { return c_; }

 private:
  E2eConfig c_;
  bool synced_ = false;
  std::uint8_t last_ = 0;
};

// Sender state: counter advances by one per protected frame.
class E2eSender {
 public:
  explicit E2eSender(E2eConfig c) : c_(c) {}
  bool protect(std::span<std::uint8_t> data) noexcept;
  [[nodiscard]] std::uint8_t next_counter() const noexcept { return counter_; }
  void set_counter(std::uint8_t v) noexcept { counter_ = static_cast<std::uint8_t>(v % counter_modulus(c_.profile)); }

 private:
  E2eConfig c_;
  std::uint8_t counter_ = 0;
};

}  // namespace sensor_rig::dbw::safety
