#pragma once
// rig-fake-gige-camera: what Aravis 0.8.26's fake cannot send, made from what it sends (issue 25
// camera.chunk_data / camera.padded_rows; camera/README.md "Mocks: faults and truth"). The fake
// streams a plain image (payload type 1, no padding); per frame this rewrites its GVSP datagrams
// into those of a camera that pads each row (GVSP x_padding, padding bytes 0xFF, a value the fake's
// ramp never has) and/or appends chunks (payload type 0x4001 image + chunks, or 4 chunk data where
// the image is the first chunk; ChunkTimestamp and ChunkExposureTime, ids in fake_cameras.hpp).
// Or a multipart frame (payload type 0x000A, GigE Vision 2.1) in extended-id packets (as Aravis
// 0.8.26 needs them: it reads the part count from the leader's packet infos): part 0 the chunks,
// part 1 the 2D image (padded rows too), each data packet naming its part and its offset in the
// buffer. The leader leaves unchanged in time; the data packets leave with the trailer (the
// frame's data is known only then), at the same packet size (multipart: 20 bytes less data, for the
// larger header).
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

namespace sensor_rig::camera::mock {

struct GvspFrameShape {
  std::uint32_t pad_bytes = 0;           // bytes after each row
  bool chunks = false;
  std::uint16_t payload_type = 0x4001;   // with chunks: 0x4001 (image + chunks) or 0x0004 (chunk data)
  std::uint64_t chunk_timestamp = 0;     // ChunkTimestamp: the leader's timestamp (ns)
  double chunk_exposure_us = 0;          // ChunkExposureTime
  bool multipart = false;                // payload type 0x000A: a chunk part, then the image part
  [[nodiscard]] bool reshaped() const noexcept { return pad_bytes > 0 || chunks || multipart; }
};

class GvspReshaper {
 public:
  using Emit = std::function<void(const std::uint8_t* data, std::size_t size)>;
  // One GVSP datagram of the fake. false: send it as it is. true: taken; `emit` got what to send
  // instead (nothing for a data packet, everything of the frame with its trailer). `shape` is read
  // at the leader and holds for the frame.
  bool feed(const std::uint8_t* data, std::size_t size, const GvspFrameShape& shape, const Emit& emit);

 private:
  // `infos_low`: the packet infos' low byte (a multipart leader's part count; extended ids only).
  void emit_packet(std::uint8_t content_type, const std::uint8_t* payload, std::size_t size, const Emit& emit,
                   std::uint8_t infos_low = 0);
  void emit_multipart_leader(const std::uint8_t* leader, const Emit& emit);
  void emit_multipart_data(const Emit& emit);

  bool active_ = false;
  GvspFrameShape shape_;
  std::uint8_t header_[4] = {};  // status and block id of this frame
  std::uint32_t packet_id_ = 0;
  std::uint32_t row_bytes_ = 0, height_ = 0, width_ = 0, pixel_format_ = 0;
  std::size_t packet_data_ = 0;  // the fake's data bytes per packet (its largest)
  std::vector<std::uint8_t> image_, out_, packet_, packet_data_buf_;
};

}  // namespace sensor_rig::camera::mock
