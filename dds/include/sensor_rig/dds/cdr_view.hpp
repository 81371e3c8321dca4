#pragma once
// Views of serialized PointCloud2 / Image samples (XCDR1, @final, as idlc's serializer writes them):
// the header, the scalar fields and a span over `data` inside the serialized buffer, no copy.
// Pure: bytes in, a view or a status out; no DDS, no I/O. Every length is checked against the
// buffer, so a malformed sample is a status (the reader counts it), never an out-of-bounds read.
// Strings and spans point into the buffer: the view lives no longer than the bytes it was parsed from.
#include <bit>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

namespace sensor_rig::dds {

enum class CdrStatus {
  kOk,
  kBadEncapsulation,  // not XCDR1 plain CDR (big or little endian), or shorter than its 4-byte header
  kTruncated,         // a field or a length runs past the end of the buffer
  kBadString,         // a string without its terminating NUL (or of length 0)
  kBadBoolean,        // a boolean other than 0 or 1
};
const char* to_string(CdrStatus s) noexcept;

// The serialized members after the encapsulation header, and their byte order. XCDR1 aligns each
// primitive to its size relative to the start of `body`.
struct CdrBody {
  std::span<const std::byte> body;
  std::endian order = std::endian::little;
};

// A serialized sample as on the wire / in a Cyclone serdata: 4-byte encapsulation header first.
std::optional<CdrBody> cdr_body(std::span<const std::byte> serialized) noexcept;

struct HeaderView {
  std::int32_t sec = 0;
  std::uint32_t nanosec = 0;
  std::string_view frame_id;
};

struct PointFieldView {
  std::string_view name;
  std::uint32_t offset = 0;
  std::uint8_t datatype = 0;
  std::uint32_t count = 0;
};

struct PointCloud2View {
  HeaderView header;
  std::uint32_t height = 0;
  std::uint32_t width = 0;
  std::vector<PointFieldView> fields;  // a handful; reused across parses when the view is
  bool is_bigendian = false;
  std::uint32_t point_step = 0;
  std::uint32_t row_step = 0;
  std::span<const std::byte> data;
  bool is_dense = false;
};

struct ImageView {
  HeaderView header;
  std::uint32_t height = 0;
  std::uint32_t width = 0;
  std::string_view encoding;
  std::uint8_t is_bigendian = 0;
  std::uint32_t step = 0;
  std::span<const std::byte> data;
};

// sensor_rig_msgs/LidarPacket(s): the raw channel of a LIDAR (msgs/idl/sensor_rig_msgs.idl).
struct LidarPacketView {
  std::int32_t sec = 0;
  std::uint32_t nanosec = 0;
  std::uint32_t src_address = 0;
  std::uint16_t src_port = 0;
  std::uint16_t dst_port = 0;
  std::span<const std::byte> data;
};

struct LidarPacketsView {
  HeaderView header;
  std::string_view model;
  std::uint16_t data_port = 0;
  std::vector<LidarPacketView> packets;  // reused across parses when the view is
};

// sensor_rig_msgs/CanFrame: the raw channel of the CAN bus.
struct CanFrameView {
  HeaderView header;
  std::uint32_t id = 0;
  bool is_rtr = false, is_extended = false, is_error = false, is_fd = false, brs = false, esi = false;
  std::span<const std::byte> data;
};

// Fill `out` from `in`; on anything but kOk `out` is unspecified and must not be used.
CdrStatus parse_cdr(const CdrBody& in, PointCloud2View& out);
CdrStatus parse_cdr(const CdrBody& in, ImageView& out);
CdrStatus parse_cdr(const CdrBody& in, LidarPacketsView& out);
CdrStatus parse_cdr(const CdrBody& in, CanFrameView& out);

}  // namespace sensor_rig::dds
