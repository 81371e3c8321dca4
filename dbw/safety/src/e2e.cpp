#include "sensor_rig/dbw/safety/e2e.hpp"

namespace sensor_rig::dbw::safety {
namespace {

constexpr std::array<std::uint8_t, 256> make_table(std::uint8_t poly) {
  std::array<std::uint8_t, 256> t{};
  for (unsigned i = 0; i < 256; ++i) {
    unsigned c = i;
    for (int b = 0; b < 8; ++b) c = (c & 0x80U) != 0 ? ((c << 1) ^ poly) : (c << 1);
    t[i] = static_cast<std::uint8_t>(c & 0xFFU);
  }
  return t;
}
constexpr auto kJ1850 = make_table(0x1D);
constexpr auto kH2F = make_table(0x2F);

std::uint8_t run(const std::array<std::uint8_t, 256>& t, std::span<const std::uint8_t> d, std::uint8_t start,
                 bool first) noexcept {
  std::uint8_t crc = first ? 0xFF : static_cast<std::uint8_t>(start ^ 0xFF);
  for (std::uint8_t b : d) crc = t[static_cast<std::uint8_t>(crc ^ b)];
  return static_cast<std::uint8_t>(crc ^ 0xFF);
}

// CRC over the payload with the CRC byte left out, continuing from `crc`.
template <class F>
std::uint8_t over_payload(F&& f, std::span<const std::uint8_t> d, std::size_t skip, std::uint8_t crc) noexcept {
  if (skip > 0) crc = f(d.subspan(0, skip), crc, false);
  if (skip + 1 < d.size()) crc = f(d.subspan(skip + 1), crc, false);
  return crc;
}

}  // namespace

std::uint8_t crc8_sae_j1850(std::span<const std::uint8_t> data, std::uint8_t start, bool first) noexcept {
  return run(kJ1850, data, start, first);
}
std::uint8_t crc8h2f(std::span<const std::uint8_t> data, std::uint8_t start, bool first) noexcept {
  return run(kH2F, data, start, first);
}

bool parse_profile(std::string_view n, E2eProfile& out) noexcept {
  if (n == "none") out = E2eProfile::kNone;
  else if (n == "counter") out = E2eProfile::kCounter;
  else if (n == "j1850") out = E2eProfile::kJ1850;
  else if (n == "p01") out = E2eProfile::kP01;
  else if (n == "p02") out = E2eProfile::kP02;
  else return false;
  return true;
}

std::string_view to_string(E2eProfile p) noexcept {
  switch (p) {
    case E2eProfile::kNone: return "none";
    case E2eProfile::kCounter: return "counter";
    case E2eProfile::kJ1850: return "j1850";
    case E2eProfile::kP01: return "p01";
    case E2eProfile::kP02: return "p02";
  }
  return "?";
}

bool parse_id_mode(std::string_view n, P01IdMode& out) noexcept {
  if (n == "both") out = P01IdMode::kBoth;
  else if (n == "alt") out = P01IdMode::kAlt;
  else if (n == "low") out = P01IdMode::kLow;
  else if (n == "nibble") out = P01IdMode::kNibble;
  else return false;
  return true;
}

std::string_view to_string(E2eStatus s) noexcept {
  switch (s) {
    case E2eStatus::kOk: return "ok";
    case E2eStatus::kOkSomeLost: return "ok_some_lost";
    case E2eStatus::kRepeated: return "repeated";
    case E2eStatus::kWrongSequence: return "wrong_sequence";
    case E2eStatus::kBadCrc: return "bad_crc";
    case E2eStatus::kBadLayout: return "bad_layout";
  }
  return "?";
}

std::uint8_t counter_modulus(E2eProfile p) noexcept { return p == E2eProfile::kP01 ? 15 : 16; }
bool has_crc(E2eProfile p) noexcept {
  return p == E2eProfile::kJ1850 || p == E2eProfile::kP01 || p == E2eProfile::kP02;
}

std::uint8_t compute_crc(const E2eConfig& c, std::span<const std::uint8_t> d, std::uint8_t counter) noexcept {
  const auto lo = static_cast<std::uint8_t>(c.data_id & 0xFFU);
  const auto hi = static_cast<std::uint8_t>(c.data_id >> 8);
  const auto j = [](std::span<const std::uint8_t> s, std::uint8_t st, bool f) { return crc8_sae_j1850(s, st, f); };
  switch (c.profile) {
    case E2eProfile::kP01: {
      // Continuing from 0xFF means an internal start of 0x00; the final XOR is undone at the end.
      std::uint8_t crc = 0xFF;
      const std::uint8_t zero = 0;
      switch (c.id_mode) {
        case P01IdMode::kBoth:
          crc = crc8_sae_j1850({&lo, 1}, crc, false);
          crc = crc8_sae_j1850({&hi, 1}, crc, false);
          break;
        case P01IdMode::kLow:
          crc = crc8_sae_j1850({&lo, 1}, crc, false);
          break;
        case P01IdMode::kAlt:
          crc = crc8_sae_j1850({(counter % 2 == 0) ? &lo : &hi, 1}, crc, false);
          break;
        case P01IdMode::kNibble:
          crc = crc8_sae_j1850({&lo, 1}, crc, false);
          crc = crc8_sae_j1850({&zero, 1}, crc, false);
          break;
      }
      crc = over_payload(j, d, c.crc_byte, crc);
      return static_cast<std::uint8_t>(crc ^ 0xFF);
    }
    case E2eProfile::kP02: {
      std::uint8_t crc = crc8h2f(d.subspan(1), 0xFF, true);
      const std::uint8_t id = c.data_id_list[counter & 0x0FU];
      return crc8h2f({&id, 1}, crc, false);
    }
    case E2eProfile::kJ1850: {
      std::uint8_t crc = 0xFF;
      bool first = true;
      if (c.crc_byte > 0) {
        crc = crc8_sae_j1850(d.subspan(0, c.crc_byte), crc, true);
        first = false;
      }
      if (c.crc_byte + 1 < d.size()) {
        crc = crc8_sae_j1850(d.subspan(c.crc_byte + 1), crc, first);
        first = false;
      }
      return crc8_sae_j1850({&lo, 1}, crc, first);
    }
    case E2eProfile::kNone:
    case E2eProfile::kCounter:
      break;
  }
  return 0;
}

std::uint8_t read_counter(const E2eConfig& c, std::span<const std::uint8_t> d) noexcept {
  if (c.counter_byte >= d.size()) return 0;
  const std::uint8_t b = d[c.counter_byte];
  return static_cast<std::uint8_t>(c.counter_high_nibble ? (b >> 4) : (b & 0x0FU));
}

namespace {
bool layout_fits(const E2eConfig& c, std::size_t size) noexcept {
  if (c.profile == E2eProfile::kNone) return true;
  if (c.counter_byte >= size) return false;
  if (has_crc(c.profile) && c.crc_byte >= size) return false;
  if (c.profile == E2eProfile::kP02 && (c.crc_byte != 0 || size < 2)) return false;
  return !(has_crc(c.profile) && c.crc_byte == c.counter_byte);
}
}  // namespace

bool protect(const E2eConfig& c, std::span<std::uint8_t> d, std::uint8_t counter) noexcept {
  if (!layout_fits(c, d.size())) return false;
  if (c.profile == E2eProfile::kNone) return true;
  counter = static_cast<std::uint8_t>(counter % counter_modulus(c.profile));
  auto& cb = d[c.counter_byte];
  cb = c.counter_high_nibble ? static_cast<std::uint8_t>((cb & 0x0FU) | (counter << 4))
                             : static_cast<std::uint8_t>((cb & 0xF0U) | counter);
  if (c.profile == E2eProfile::kP01 && c.id_mode == P01IdMode::kNibble) {
    // The Data ID high byte's low nibble travels in the other nibble of the counter byte.
    const auto nib = static_cast<std::uint8_t>((c.data_id >> 8) & 0x0FU);
    cb = c.counter_high_nibble ? static_cast<std::uint8_t>((cb & 0xF0U) | nib)
                               : static_cast<std::uint8_t>((cb & 0x0FU) | (nib << 4));
  }
  if (has_crc(c.profile)) d[c.crc_byte] = compute_crc(c, d, counter);
  return true;
}

E2eStatus E2eChecker::check(std::span<const std::uint8_t> d) noexcept {
  if (c_.profile == E2eProfile::kNone) return E2eStatus::kOk;
  if (!layout_fits(c_, d.size())) return E2eStatus::kBadLayout;
  const std::uint8_t counter = read_counter(c_, d);
  const std::uint8_t mod = counter_modulus(c_.profile);
  if (counter >= mod) return E2eStatus::kBadLayout;
  if (c_.profile == E2eProfile::kP01 && c_.id_mode == P01IdMode::kNibble) {
    const std::uint8_t b = d[c_.counter_byte];
    const auto nib = static_cast<std::uint8_t>(c_.counter_high_nibble ? (b & 0x0FU) : (b >> 4));
    if (nib != ((c_.data_id >> 8) & 0x0FU)) return E2eStatus::kBadCrc;
  }
  if (has_crc(c_.profile) && d[c_.crc_byte] != compute_crc(c_, d, counter)) return E2eStatus::kBadCrc;
  if (!synced_) {
    synced_ = true;
    last_ = counter;
    return E2eStatus::kOk;
  }
  const auto delta = static_cast<std::uint8_t>((counter + mod - last_) % mod);
  if (delta == 0) return E2eStatus::kRepeated;
  if (delta > c_.max_delta) {
    last_ = counter;  // resynchronise on the new sequence
    return E2eStatus::kWrongSequence;
  }
  last_ = counter;
  return delta == 1 ? E2eStatus::kOk : E2eStatus::kOkSomeLost;
}

bool E2eSender::protect(std::span<std::uint8_t> d) noexcept {
  if (!safety::protect(c_, d, counter_)) return false;
  counter_ = static_cast<std::uint8_t>((counter_ + 1) % counter_modulus(c_.profile));
  return true;
}

}  // namespace sensor_rig::dbw::safety
