#include "gvsp_reshaper.hpp"

#include <algorithm>
#include <bit>
#include <cstring>

#include "gvsp_format.hpp"
#include "sensor_rig/camera/mock/fake_cameras.hpp"

namespace sensor_rig::camera::mock {
namespace {

using gvsp::kHeader;
using gvsp::kLeader;
using gvsp::kPayload;
using gvsp::kTrailer;
// Image leader, after the header: flags 0, payload type 2, timestamp 4..11, pixel format 12,
// width 16, height 20, x/y offset 24/28, x padding 32, y padding 34.
constexpr std::size_t kPayloadType = kHeader + 2, kPixelFormat = kHeader + 12, kWidth = kHeader + 16,
                      kHeight = kHeader + 20, kXPadding = kHeader + 32, kLeaderEnd = kHeader + 36;
constexpr std::uint8_t kPadByte = 0xFF;

std::uint32_t be32(const std::uint8_t* p) noexcept {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
}
void put_be(std::vector<std::uint8_t>& out, std::uint64_t v, int bytes) {
  for (int i = bytes - 1; i >= 0; --i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
void put_be16(std::uint8_t* p, std::uint32_t v) noexcept {
  p[0] = static_cast<std::uint8_t>(v >> 8);
  p[1] = static_cast<std::uint8_t>(v);
}
// A chunk: its data, then its id and length (big endian, as the leader's chunk flag says).
void put_chunk_tag(std::vector<std::uint8_t>& out, std::uint32_t id, std::size_t length) {
  put_be(out, id, 4);
  put_be(out, length, 4);
}

}  // namespace

void GvspReshaper::emit_packet(std::uint8_t content_type, const std::uint8_t* payload, std::size_t size, const Emit& emit) {
  packet_.resize(kHeader + size);
  std::memcpy(packet_.data(), header_, 4);
  const std::uint32_t infos = (std::uint32_t{content_type} << 24) | (packet_id_++ & 0x00ffffffu);
  for (int i = 0; i < 4; ++i) packet_[static_cast<std::size_t>(4 + i)] = static_cast<std::uint8_t>(infos >> (24 - 8 * i));
  if (size > 0) std::memcpy(packet_.data() + kHeader, payload, size);
  emit(packet_.data(), packet_.size());
}

bool GvspReshaper::feed(const std::uint8_t* data, std::size_t size, const GvspFrameShape& shape, const Emit& emit) {
  if (size < kHeader) return false;
  const std::uint8_t type = data[4] & 0x7f;
  if (type == kLeader) {
    active_ = shape.reshaped() && size >= kLeaderEnd;
    if (!active_) return false;
    shape_ = shape;
    std::memcpy(header_, data, 4);
    const std::uint32_t bits = (be32(data + kPixelFormat) >> 16) & 0xff;
    row_bytes_ = be32(data + kWidth) * bits / 8;
    height_ = be32(data + kHeight);
    image_.clear();
    packet_data_ = 0;
    std::vector<std::uint8_t> leader(data, data + size);
    put_be16(leader.data() + kPayloadType, shape_.chunks ? shape_.payload_type : 0x0001u);
    put_be16(leader.data() + kXPadding, shape_.pad_bytes);
    packet_id_ = 0;
    emit_packet(kLeader, leader.data() + kHeader, leader.size() - kHeader, emit);
    return true;
  }
  if (!active_) return false;
  if (type == kPayload) {
    image_.insert(image_.end(), data + kHeader, data + size);
    packet_data_ = std::max(packet_data_, size - kHeader);
    return true;
  }
  if (type != kTrailer) return true;  // nothing else in a fake's frame
  active_ = false;
  // The payload as the camera would send it: each row followed by its padding, then the chunks.
  out_.clear();
  out_.reserve(std::size_t{row_bytes_ + shape_.pad_bytes} * height_ + kChaosChunkTrailerBytes);
  for (std::uint32_t r = 0; r < height_; ++r) {
    const std::size_t at = std::size_t{r} * row_bytes_;
    if (at + row_bytes_ > image_.size()) break;
    out_.insert(out_.end(), image_.begin() + static_cast<std::ptrdiff_t>(at), image_.begin() + static_cast<std::ptrdiff_t>(at + row_bytes_));
    out_.insert(out_.end(), shape_.pad_bytes, kPadByte);
  }
  if (shape_.chunks) {
    put_chunk_tag(out_, kChaosChunkIdImage, out_.size());
    put_be(out_, shape_.chunk_timestamp, 8);
    put_chunk_tag(out_, kChaosChunkIdTimestamp, 8);
    put_be(out_, std::bit_cast<std::uint64_t>(shape_.chunk_exposure_us), 8);
    put_chunk_tag(out_, kChaosChunkIdExposure, 8);
  }
  const std::size_t step = packet_data_ > 0 ? packet_data_ : out_.size();
  for (std::size_t at = 0; at < out_.size(); at += step)
    emit_packet(kPayload, out_.data() + at, std::min(step, out_.size() - at), emit);
  std::vector<std::uint8_t> trailer(data + kHeader, data + size);
  if (trailer.size() >= 4) {  // its payload type (32 bits) says what the leader said
    trailer[0] = trailer[1] = 0;
    put_be16(trailer.data() + 2, shape_.chunks ? shape_.payload_type : 0x0001u);
  }
  emit_packet(kTrailer, trailer.data(), trailer.size(), emit);
  return true;
}

}  // namespace sensor_rig::camera::mock
