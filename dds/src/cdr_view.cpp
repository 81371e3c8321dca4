#include "sensor_rig/dds/cdr_view.hpp"

#include <cstring>

namespace sensor_rig::dds {
namespace {

// Encapsulation identifiers (DDS-XTypes 7.6.3.1.2): plain CDR, XCDR1.
constexpr std::uint16_t kCdrBigEndian = 0x0000;
constexpr std::uint16_t kCdrLittleEndian = 0x0001;
constexpr std::size_t kEncapsulationBytes = 4;

// Reads members in order with XCDR1 alignment; the first failure sticks (later reads return 0).
class CdrCursor {
 public:
  explicit CdrCursor(const CdrBody& in) noexcept : buf_(in.body), swap_(in.order != std::endian::native) {}

  [[nodiscard]] CdrStatus status() const noexcept { return status_; }

  std::uint8_t u8() noexcept {
    const auto b = take(1, 1);
    return b.empty() ? 0 : static_cast<std::uint8_t>(b[0]);
  }
  bool boolean() noexcept {
    const std::uint8_t v = u8();
    if (v > 1) fail(CdrStatus::kBadBoolean);
    return v == 1;
  }
  std::uint32_t u32() noexcept {
    const auto b = take(4, 4);
    if (b.empty()) return 0;
    std::uint32_t v = 0;
    std::memcpy(&v, b.data(), sizeof v);
    return swap_ ? __builtin_bswap32(v) : v;  // std::byteswap is C++23
  }
  std::int32_t i32() noexcept { return static_cast<std::int32_t>(u32()); }
  std::uint16_t u16() noexcept {
    const auto b = take(2, 2);
    if (b.empty()) return 0;
    std::uint16_t v = 0;
    std::memcpy(&v, b.data(), sizeof v);
    return swap_ ? __builtin_bswap16(v) : v;
  }
  // Length (with the NUL) then the characters; the view leaves the NUL out.
  std::string_view string() noexcept {
    const std::uint32_t n = u32();
    if (status_ != CdrStatus::kOk) return {};
    const auto b = n == 0 ? std::span<const std::byte>{} : take(n, 1);
    if (b.empty() || b[n - 1] != std::byte{0}) {
      fail(CdrStatus::kBadString);  // keeps kTruncated when take() failed
      return {};
    }
    return {reinterpret_cast<const char*>(b.data()), n - 1};
  }
  std::span<const std::byte> octets() noexcept {
    const std::uint32_t n = u32();
    if (status_ != CdrStatus::kOk || n == 0) return {};
    return take(n, 1);
  }
  // A sequence length that at least `min_element_bytes` per element must fit in what is left.
  std::uint32_t sequence_length(std::size_t min_element_bytes) noexcept {
    const std::uint32_t n = u32();
    if (status_ == CdrStatus::kOk && n > (buf_.size() - at_) / min_element_bytes) fail(CdrStatus::kTruncated);
    return status_ == CdrStatus::kOk ? n : 0;
  }
  HeaderView header() noexcept {
    HeaderView h;
    h.sec = i32();
    h.nanosec = u32();
    h.frame_id = string();
    return h;
  }

 private:
  // `n` bytes at the next multiple of `align` (relative to the body's start), or empty on failure.
  std::span<const std::byte> take(std::size_t n, std::size_t align) noexcept {
    if (status_ != CdrStatus::kOk) return {};
    const std::size_t start = (at_ + align - 1) & ~(align - 1);
    if (start > buf_.size() || n > buf_.size() - start) {
      fail(CdrStatus::kTruncated);
      return {};
    }
    at_ = start + n;
    return buf_.subspan(start, n);
  }
  void fail(CdrStatus s) noexcept {
    if (status_ == CdrStatus::kOk) status_ = s;
  }

  std::span<const std::byte> buf_;
  std::size_t at_ = 0;
  bool swap_ = false;
  CdrStatus status_ = CdrStatus::kOk;
};

// Both messages start with header, height, width.
template <class View>
void read_header_and_size(CdrCursor& c, View& out) {
  out.header = c.header();
  out.height = c.u32();
  out.width = c.u32();
}

// Smallest serialized LidarPacket: stamp, address, ports, data length.
constexpr std::size_t kMinLidarPacketBytes = 8 + 4 + 2 + 2 + 4;

// Smallest serialized PointField: name length + NUL, offset, datatype, padding, count.
constexpr std::size_t kMinPointFieldBytes = 4 + 1 + 3 + 4 + 1 + 3 + 4;

}  // namespace

const char* to_string(CdrStatus s) noexcept {
  switch (s) {
    case CdrStatus::kOk: return "ok";
    case CdrStatus::kBadEncapsulation: return "not XCDR1 plain CDR";
    case CdrStatus::kTruncated: return "truncated";
    case CdrStatus::kBadString: return "string without NUL";
    case CdrStatus::kBadBoolean: return "boolean not 0/1";
  }
  return "unknown";
}

std::optional<CdrBody> cdr_body(std::span<const std::byte> serialized) noexcept {
  if (serialized.size() < kEncapsulationBytes) return std::nullopt;
  // The identifier is big-endian on the wire whatever the body's order.
  const auto id = static_cast<std::uint16_t>((std::to_integer<unsigned>(serialized[0]) << 8) |
                                             std::to_integer<unsigned>(serialized[1]));
  if (id != kCdrBigEndian && id != kCdrLittleEndian) return std::nullopt;
  return CdrBody{serialized.subspan(kEncapsulationBytes), id == kCdrLittleEndian ? std::endian::little : std::endian::big};
}

CdrStatus parse_cdr(const CdrBody& in, PointCloud2View& out) {
  CdrCursor c(in);
  read_header_and_size(c, out);
  const std::uint32_t n_fields = c.sequence_length(kMinPointFieldBytes);
  out.fields.clear();
  out.fields.reserve(n_fields);
  for (std::uint32_t i = 0; i < n_fields && c.status() == CdrStatus::kOk; ++i) {
    PointFieldView f;
    f.name = c.string();
    f.offset = c.u32();
    f.datatype = c.u8();
    f.count = c.u32();
    out.fields.push_back(f);
  }
  out.is_bigendian = c.boolean();
  out.point_step = c.u32();
  out.row_step = c.u32();
  out.data = c.octets();
  out.is_dense = c.boolean();
  return c.status();
}

CdrStatus parse_cdr(const CdrBody& in, ImageView& out) {
  CdrCursor c(in);
  read_header_and_size(c, out);
  out.encoding = c.string();
  out.is_bigendian = c.u8();
  out.step = c.u32();
  out.data = c.octets();
  return c.status();
}

CdrStatus parse_cdr(const CdrBody& in, LidarPacketsView& out) {
  CdrCursor c(in);
  out.header = c.header();
  out.model = c.string();
  out.data_port = c.u16();
  const std::uint32_t n = c.sequence_length(kMinLidarPacketBytes);
  out.packets.clear();
  out.packets.reserve(n);
  for (std::uint32_t i = 0; i < n && c.status() == CdrStatus::kOk; ++i) {
    LidarPacketView p;
    p.sec = c.i32();
    p.nanosec = c.u32();
    p.src_address = c.u32();
    p.src_port = c.u16();
    p.dst_port = c.u16();
    p.data = c.octets();
    out.packets.push_back(p);
  }
  return c.status();
}

CdrStatus parse_cdr(const CdrBody& in, CanFrameView& out) {
  CdrCursor c(in);
  out.header = c.header();
  out.id = c.u32();
  out.is_rtr = c.boolean();
  out.is_extended = c.boolean();
  out.is_error = c.boolean();
  out.is_fd = c.boolean();
  out.brs = c.boolean();
  out.esi = c.boolean();
  out.data = c.octets();
  return c.status();
}

}  // namespace sensor_rig::dds
