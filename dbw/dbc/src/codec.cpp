// Bit layout: position p = byte * 8 + bit (bit 0 = LSB of the byte).
// Intel (@1): start bit is the LSB, the signal runs upwards. Motorola (@0): start bit is the MSB;
// from it the signal runs down to bit 0 of the byte, then continues at bit 7 of the next byte.
#include "sensor_rig/dbw/dbc/codec.hpp"

#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>

namespace sensor_rig::dbw::dbc {
namespace {

constexpr int kMaxBit = static_cast<int>(kMaxFrameBytes * 8);

// Calls f(position, index_from_msb) for every bit, MSB first. Returns false if a position is invalid.
template <class F>
bool for_each_bit(const Signal& s, F&& f) noexcept {
  const int len = s.length;
  if (s.order == ByteOrder::kMotorola) {
    int pos = s.start_bit;
    for (int i = 0; i < len; ++i) {
      if (pos < 0 || pos >= kMaxBit) return false;
      f(pos, i);
      pos = (pos % 8 == 0) ? pos + 15 : pos - 1;
    }
  } else {
    for (int i = 0; i < len; ++i) {
      const int pos = s.start_bit + (len - 1 - i);
      if (pos >= kMaxBit) return false;
      f(pos, i);
    }
  }
  return true;
}

constexpr std::uint64_t mask_of(int len) noexcept { return len >= 64 ? ~0ULL : ((1ULL << len) - 1ULL); }

}  // namespace

std::size_t signal_extent(const Signal& s) noexcept {
  int highest = -1;
  const bool ok = for_each_bit(s, [&](int pos, int) { highest = pos > highest ? pos : highest; });
  if (!ok || highest < 0) return 0;
  return static_cast<std::size_t>(highest / 8) + 1;
}

bool signal_fits(const Signal& s, std::size_t frame_bytes) noexcept {
  const std::size_t e = signal_extent(s);
  return e != 0 && e <= frame_bytes;
}

std::optional<std::uint64_t> extract_raw(const Signal& s, std::span<const std::uint8_t> data) noexcept {
  const std::size_t need = signal_extent(s);
  if (need == 0 || need > data.size()) return std::nullopt;
  std::uint64_t raw = 0;
  if (s.order == ByteOrder::kIntel) {
    // Fast path: gather the covered bytes little-endian, then shift.
    const int first = s.start_bit / 8;
    const int shift = s.start_bit % 8;
    const int last = (s.start_bit + s.length - 1) / 8;
    const int top = last - first >= 8 ? first + 7 : last;
    std::uint64_t acc = 0;
    for (int b = top; b >= first; --b) acc = (acc << 8) | data[static_cast<std::size_t>(b)];
    raw = acc >> shift;
    if (top != last && shift != 0) raw |= static_cast<std::uint64_t>(data[static_cast<std::size_t>(last)]) << (64 - shift);
    return raw & mask_of(s.length);
  }
  for_each_bit(s, [&](int pos, int) {
    raw = (raw << 1) | ((data[static_cast<std::size_t>(pos / 8)] >> (pos % 8)) & 1U);
  });
  return raw;
}

bool insert_raw(const Signal& s, std::uint64_t raw, std::span<std::uint8_t> data) noexcept {
  const std::size_t need = signal_extent(s);
  if (need == 0 || need > data.size()) return false;
  const int len = s.length;
  raw &= mask_of(len);
  for_each_bit(s, [&](int pos, int i) {
    const unsigned bit = static_cast<unsigned>((raw >> (len - 1 - i)) & 1ULL);
    auto& byte = data[static_cast<std::size_t>(pos / 8)];
    const auto m = static_cast<std::uint8_t>(1U << (pos % 8));
    byte = static_cast<std::uint8_t>(bit != 0 ? (byte | m) : (byte & ~m));
  });
  return true;
}

double to_physical(const Signal& s, std::uint64_t raw) noexcept {
  double v = 0.0;
  switch (s.value_type) {
    case ValueType::kFloat32:
      v = static_cast<double>(std::bit_cast<float>(static_cast<std::uint32_t>(raw)));
      break;
    case ValueType::kFloat64:
      v = std::bit_cast<double>(raw);
      break;
    case ValueType::kInteger:
      if (s.is_signed) {
        std::uint64_t r = raw;
        if (s.length < 64 && ((r >> (s.length - 1)) & 1ULL) != 0) r |= ~mask_of(s.length);
        v = static_cast<double>(static_cast<std::int64_t>(r));
      } else {
        v = static_cast<double>(raw);
      }
      break;
  }
  return v * s.factor + s.offset;
}

std::optional<double> decode(const Signal& s, std::span<const std::uint8_t> data) noexcept {
  const auto raw = extract_raw(s, data);
  if (!raw) return std::nullopt;
  return to_physical(s, *raw);
}

EncodeStatus to_raw(const Signal& s, double physical, std::uint64_t& raw) noexcept {
  if (!std::isfinite(physical)) return EncodeStatus::kNotFinite;
  const double scaled = (physical - s.offset) / s.factor;
  if (s.value_type == ValueType::kFloat32) {
    raw = std::bit_cast<std::uint32_t>(static_cast<float>(scaled));
    return EncodeStatus::kOk;
  }
  if (s.value_type == ValueType::kFloat64) {
    raw = std::bit_cast<std::uint64_t>(scaled);
    return EncodeStatus::kOk;
  }
  double v = std::nearbyint(scaled);
  double lo = 0.0;
  double hi = 0.0;
  if (s.is_signed) {
    lo = -std::ldexp(1.0, s.length - 1);
    hi = s.length >= 54 ? std::nextafter(-lo, 0.0) : -lo - 1.0;
  } else {
    hi = s.length >= 53 ? std::nextafter(std::ldexp(1.0, s.length), 0.0) : std::ldexp(1.0, s.length) - 1.0;
  }
  EncodeStatus st = EncodeStatus::kOk;
  if (v < lo) {
    v = lo;
    st = EncodeStatus::kClamped;
  } else if (v > hi) {
    v = hi;
    st = EncodeStatus::kClamped;
  }
  raw = s.is_signed ? static_cast<std::uint64_t>(static_cast<std::int64_t>(v)) : static_cast<std::uint64_t>(v);
  raw &= mask_of(s.length);
  return st;
}

EncodeStatus encode(const Signal& s, double physical, std::span<std::uint8_t> data) noexcept {
  std::uint64_t raw = 0;
  const EncodeStatus st = to_raw(s, physical, raw);
  if (st == EncodeStatus::kNotFinite) return st;
  if (!insert_raw(s, raw, data)) return EncodeStatus::kOutOfFrame;
  return st;
}

bool signal_active(const Message& m, const Signal& s, std::span<const std::uint8_t> data) noexcept {
  if (s.mux != MuxRole::kMultiplexed) return true;
  const Signal* mux = m.multiplexor();
  if (mux == nullptr) return false;
  const auto raw = extract_raw(*mux, data);
  return raw && *raw == s.mux_value;
}

std::string format_value(const Signal& s, double physical) {
  if (physical == 0.0) physical = 0.0;  // no "-0"
  char buf[64];
  if (s.value_type == ValueType::kInteger && s.decimals <= 15 && std::fabs(physical) < 1e15) {
    const int n = std::snprintf(buf, sizeof buf, "%.*f", s.decimals, physical);
    std::string out(buf, static_cast<std::size_t>(n));
    if (out == "-0" || (out.rfind("-0.", 0) == 0 && out.find_first_not_of("-0.") == std::string::npos)) {
      out.erase(0, 1);
    }
    return out;
  }
  const auto r = std::to_chars(buf, buf + sizeof buf, physical);
  return std::string(buf, r.ptr);
}

}  // namespace sensor_rig::dbw::dbc
