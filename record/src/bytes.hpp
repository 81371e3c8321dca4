#pragma once
// Little-endian MCAP primitives: appending to a buffer, and a bounds-checked cursor over bytes.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <map>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace sensor_rig::record {

// Every MCAP record: its opcode (1 byte), then its body's length (u64).
constexpr std::size_t kRecordHeader = 9;

// An opcode as "0x.." for error messages.
inline std::string hex_op(std::uint8_t op) {
  constexpr char kHex[] = "0123456789abcdef";
  return std::string("0x") + kHex[op >> 4] + kHex[op & 15];
}

class Out {
 public:
  explicit Out(std::vector<std::byte>& b) : b_(b) {}
  template <class T>
  void le(T v) {
    for (std::size_t i = 0; i < sizeof(T); ++i) b_.push_back(static_cast<std::byte>((static_cast<std::uint64_t>(v) >> (8 * i)) & 0xff));
  }
  void raw(std::span<const std::byte> s) { b_.insert(b_.end(), s.begin(), s.end()); }
  void str(std::string_view s) {
    le(static_cast<std::uint32_t>(s.size()));
    raw(std::as_bytes(std::span<const char>(s.data(), s.size())));
  }
  void map(const std::map<std::string, std::string>& m) {
    std::size_t n = 0;
    for (const auto& [k, v] : m) n += 8 + k.size() + v.size();
    le(static_cast<std::uint32_t>(n));
    for (const auto& [k, v] : m) {
      str(k);
      str(v);
    }
  }
  // Starts a record: opcode and a length patched by end_record().
  std::size_t begin_record(std::uint8_t op) {
    le(op);
    const std::size_t at = b_.size();
    le(std::uint64_t{0});
    return at;
  }
  void end_record(std::size_t at) {
    const std::uint64_t n = b_.size() - at - 8;
    for (std::size_t i = 0; i < 8; ++i) b_[at + i] = static_cast<std::byte>((n >> (8 * i)) & 0xff);
  }
  [[nodiscard]] std::size_t size() const { return b_.size(); }

 private:
  std::vector<std::byte>& b_;
};

// Reads fields in order; any read past the end sets ok() false and returns zeros/empties.
class In {
 public:
  explicit In(std::span<const std::byte> s) : s_(s) {}
  template <class T>
  T le() {
    if (!need(sizeof(T))) return T{};
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < sizeof(T); ++i) v |= static_cast<std::uint64_t>(std::to_integer<unsigned>(s_[pos_ + i])) << (8 * i);
    pos_ += sizeof(T);
    return static_cast<T>(v);
  }
  std::span<const std::byte> bytes(std::size_t n) {
    if (!need(n)) return {};
    const auto r = s_.subspan(pos_, n);
    pos_ += n;
    return r;
  }
  std::string str() {
    const auto n = le<std::uint32_t>();
    const auto b = bytes(n);
    return std::string(reinterpret_cast<const char*>(b.data()), b.size());
  }
  std::map<std::string, std::string> map() {
    std::map<std::string, std::string> m;
    In inner(bytes(le<std::uint32_t>()));
    while (ok_ && inner.ok() && inner.left() > 0) {
      std::string k = inner.str();
      std::string v = inner.str();
      if (inner.ok()) m.emplace(std::move(k), std::move(v));
    }
    if (!inner.ok()) ok_ = false;
    return m;
  }
  std::span<const std::byte> rest() { return bytes(left()); }
  [[nodiscard]] bool ok() const { return ok_; }
  [[nodiscard]] std::size_t left() const { return s_.size() - pos_; }
  [[nodiscard]] std::size_t pos() const { return pos_; }

 private:
  bool need(std::size_t n) {
    if (!ok_ || s_.size() - pos_ < n) {
      ok_ = false;
      return false;
    }
    return true;
  }
  std::span<const std::byte> s_;
  std::size_t pos_ = 0;
  bool ok_ = true;
};

}  // namespace sensor_rig::record
