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
// Extended-id header: status 2, flags 2, packet infos 4 (bit 31: extended ids), block id 8, packet
// id 4. Multipart: content type 7; its data packets begin with part id 1, zone 1, offset 6.
constexpr std::size_t kExtendedHeader = 20, kMultipartData = 8;
constexpr std::uint8_t kMultipart = 7;
constexpr std::uint16_t kMultipartPayload = 0x000A;
constexpr std::uint16_t kPartChunkData = 0x000A, kPartImage2D = 0x0001;
constexpr std::size_t kChunkPartBytes = 32;  // ChunkTimestamp and ChunkExposureTime, each with its tag

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
void put_be32(std::uint8_t* p, std::uint32_t v) noexcept {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (24 - 8 * i));
}
// A multipart leader's part infos (48 bytes, GigE Vision 2.1; ArvGvspPartInfos).
void put_part_infos(std::vector<std::uint8_t>& out, std::uint16_t data_type, std::uint64_t length, std::uint32_t pixel_format,
                    std::uint32_t width, std::uint32_t height, std::uint16_t x_padding) {
  put_be(out, data_type, 2);
  put_be(out, length >> 32, 2);
  put_be(out, length & 0xffffffffu, 4);
  put_be(out, pixel_format, 4);
  put_be(out, 0, 2 + 1 + 1 + 4 + 2 + 2);  // reserved, source id, additional zones, zone directions, purpose, region
  put_be(out, width, 4);
  put_be(out, height, 4);
  put_be(out, 0, 4 + 4);  // x, y offset
  put_be(out, x_padding, 2);
  put_be(out, 0, 2 + 4);  // y padding, reserved
}
// A chunk: its data, then its id and length (big endian, as the leader's chunk flag says).
void put_chunk_tag(std::vector<std::uint8_t>& out, std::uint32_t id, std::size_t length) {
  put_be(out, id, 4);
  put_be(out, length, 4);
}

}  // namespace

void GvspReshaper::emit_packet(std::uint8_t content_type, const std::uint8_t* payload, std::size_t size, const Emit& emit,
                               std::uint8_t infos_low) {
  if (!shape_.multipart) {
    packet_.resize(kHeader + size);
    std::memcpy(packet_.data(), header_, 4);
    put_be32(packet_.data() + 4, (std::uint32_t{content_type} << 24) | (packet_id_++ & 0x00ffffffu));
    if (size > 0) std::memcpy(packet_.data() + kHeader, payload, size);
  } else {
    packet_.assign(kExtendedHeader + size, 0);
    std::memcpy(packet_.data(), header_, 2);  // status; flags 0
    put_be32(packet_.data() + 4, 0x80000000u | (std::uint32_t{content_type} << 24) | infos_low);
    put_be32(packet_.data() + 12, (std::uint32_t{header_[2]} << 8) | header_[3]);  // the block id, 64 bits
    put_be32(packet_.data() + 16, packet_id_++);
    if (size > 0) std::memcpy(packet_.data() + kExtendedHeader, payload, size);
  }
  emit(packet_.data(), packet_.size());
}

void GvspReshaper::emit_multipart_leader(const std::uint8_t* leader, const Emit& emit) {
  std::vector<std::uint8_t> out;
  put_be(out, 0, 2);  // flags
  put_be(out, kMultipartPayload, 2);
  out.insert(out.end(), leader + kHeader + 4, leader + kHeader + 12);  // the timestamp, as the fake sent it
  put_part_infos(out, kPartChunkData, kChunkPartBytes, 0, 0, 0, 0);
  put_part_infos(out, kPartImage2D, std::uint64_t{row_bytes_ + shape_.pad_bytes} * height_, pixel_format_, width_, height_,
                 static_cast<std::uint16_t>(shape_.pad_bytes));
  emit_packet(kLeader, out.data(), out.size(), emit, 2);
}

void GvspReshaper::emit_multipart_data(const Emit& emit) {
  // out_ holds the parts back to back: each packet carries one part's bytes and their offset in
  // the buffer (where Aravis copies them).
  const std::size_t step = packet_data_ > kExtendedHeader - kHeader + kMultipartData
                               ? packet_data_ - (kExtendedHeader - kHeader) - kMultipartData
                               : out_.size();
  const std::size_t bounds[3] = {0, kChunkPartBytes, out_.size()};
  for (std::uint8_t part = 0; part < 2; ++part)
    for (std::size_t at = bounds[part]; at < bounds[part + 1]; at += step) {
      const std::size_t n = std::min(step, bounds[part + 1] - at);
      packet_data_buf_.clear();
      put_be(packet_data_buf_, part, 1);
      put_be(packet_data_buf_, 0, 1);  // zone info
      put_be(packet_data_buf_, at, 6);
      packet_data_buf_.insert(packet_data_buf_.end(), out_.begin() + static_cast<std::ptrdiff_t>(at),
                              out_.begin() + static_cast<std::ptrdiff_t>(at + n));
      emit_packet(kMultipart, packet_data_buf_.data(), packet_data_buf_.size(), emit);
    }
}

bool GvspReshaper::feed(const std::uint8_t* data, std::size_t size, const GvspFrameShape& shape, const Emit& emit) {
  if (size < kHeader) return false;
  const std::uint8_t type = data[4] & 0x7f;
  if (type == kLeader) {
    active_ = shape.reshaped() && size >= kLeaderEnd;
    if (!active_) return false;
    shape_ = shape;
    std::memcpy(header_, data, 4);
    pixel_format_ = be32(data + kPixelFormat);
    const std::uint32_t bits = (pixel_format_ >> 16) & 0xff;
    width_ = be32(data + kWidth);
    row_bytes_ = width_ * bits / 8;
    height_ = be32(data + kHeight);
    image_.clear();
    packet_data_ = 0;
    packet_id_ = 0;
    if (shape_.multipart) {
      emit_multipart_leader(data, emit);
      return true;
    }
    std::vector<std::uint8_t> leader(data, data + size);
    put_be16(leader.data() + kPayloadType, shape_.chunks ? shape_.payload_type : 0x0001u);
    put_be16(leader.data() + kXPadding, shape_.pad_bytes);
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
  if (shape_.multipart) {  // part 0: the chunks (no image chunk: the image is a part of its own)
    put_be(out_, shape_.chunk_timestamp, 8);
    put_chunk_tag(out_, kChaosChunkIdTimestamp, 8);
    put_be(out_, std::bit_cast<std::uint64_t>(shape_.chunk_exposure_us), 8);
    put_chunk_tag(out_, kChaosChunkIdExposure, 8);
  }
  for (std::uint32_t r = 0; r < height_; ++r) {
    const std::size_t at = std::size_t{r} * row_bytes_;
    if (at + row_bytes_ > image_.size()) break;
    out_.insert(out_.end(), image_.begin() + static_cast<std::ptrdiff_t>(at), image_.begin() + static_cast<std::ptrdiff_t>(at + row_bytes_));
    out_.insert(out_.end(), shape_.pad_bytes, kPadByte);
  }
  if (shape_.chunks && !shape_.multipart) {
    put_chunk_tag(out_, kChaosChunkIdImage, out_.size());
    put_be(out_, shape_.chunk_timestamp, 8);
    put_chunk_tag(out_, kChaosChunkIdTimestamp, 8);
    put_be(out_, std::bit_cast<std::uint64_t>(shape_.chunk_exposure_us), 8);
    put_chunk_tag(out_, kChaosChunkIdExposure, 8);
  }
  if (shape_.multipart) {
    emit_multipart_data(emit);
  } else {
    const std::size_t step = packet_data_ > 0 ? packet_data_ : out_.size();
    for (std::size_t at = 0; at < out_.size(); at += step)
      emit_packet(kPayload, out_.data() + at, std::min(step, out_.size() - at), emit);
  }
  std::vector<std::uint8_t> trailer(data + kHeader, data + size);
  if (trailer.size() >= 4) {  // its payload type (32 bits) says what the leader said
    trailer[0] = trailer[1] = 0;
    put_be16(trailer.data() + 2, shape_.multipart ? kMultipartPayload : shape_.chunks ? shape_.payload_type : 0x0001u);
  }
  emit_packet(kTrailer, trailer.data(), trailer.size(), emit);
  return true;
}

}  // namespace sensor_rig::camera::mock
