#pragma once
// What a GigE Vision buffer holds beside a plain image (issue 27 items 3 and 13): where the image is
// in a buffer of any payload type (image, image with chunks, chunk data, multipart), the row stride
// it really has (GVSP row padding), and the chunk values (ChunkTimestamp, ChunkExposureTime) a
// camera in chunk mode appends to each frame. Used by AravisSource::next() on the capture thread.
#include <arv.h>

#include <cstddef>
#include <cstdint>
#include <mutex>
#include <string>

#include "chunk_layout.hpp"
#include "sensor_rig/camera/pixel_format.hpp"
#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::camera::detail {

// The image of a completed buffer: `offset` bytes into the buffer's data, rows `step` bytes apart
// (row bytes + the camera's padding), `height` rows. error non-empty: no usable image of this size.
struct LocatedImage {
  std::size_t offset = 0;
  std::uint32_t step = 0;
  std::string error;
};
// `data`/`size`: the buffer's memory (arv_buffer_get_data). Image and image-with-chunks buffers:
// the leader's size and padding; chunk data (payload type 4, no image infos): the first chunk, its
// stride its length / height; multipart: the 2D image part of this size.
LocatedImage locate_image(ArvBuffer* buffer, std::uint32_t width, std::uint32_t height, PixelFormat format);

// The GVSP payload of a buffer, for the camera's status: "image", "image+chunks", "chunk_data",
// "extended_chunk_data", "multipart" or "other" (a static string).
const char* payload_name(ArvBuffer* buffer);

// The image chunk of a chunk-data buffer: the chunk at offset 0, walked from the end as Aravis does
// (data, then id and length, big endian). Returns its length, 0 when the layout does not add up.
std::size_t first_chunk_bytes(const std::uint8_t* data, std::size_t size);

// GevTimestampTickFrequency where the device has it (a GVCP read: at open only), else 0.
std::uint64_t timestamp_tick_hz(ArvDevice* device);

// Aravis' GenICam XML parsing (a camera's open, a chunk parser) is not safe from two threads at
// once: two capture threads making their chunk parsers together corrupted the heap ("malloc():
// unaligned tcache chunk detected" in arv_gc_new, rig chaos with chunk data on two cameras at the
// same second, 1 run in ~16). Every such parse holds this.
std::mutex& genicam_parse_mutex();

// Per-frame chunk values through the camera's own GenICam chunk features (ChunkTimestamp in device
// ticks, ChunkExposureTime in us). Image and chunk-data buffers: Aravis' chunk parser, made from the
// device's XML once, at the first buffer with chunks (no I/O: the XML is the one read at open).
// Multipart buffers, which that parser cannot read: the chunk part, at the places the features'
// registers give (chunk_layout.hpp), resolved at open.
class ChunkReader {
 public:
  struct Values {
    Nanos timestamp_ns = 0;  // ChunkTimestamp in ns of the device clock; 0: absent
    Nanos exposure_ns = 0;   // ChunkExposureTime; 0: absent
  };
  ChunkReader() = default;
  ~ChunkReader();
  ChunkReader(const ChunkReader&) = delete;
  ChunkReader& operator=(const ChunkReader&) = delete;

  // `tick_hz`: the device's timestamp tick frequency (GevTimestampTickFrequency; 0: 1 GHz).
  void set_tick_hz(std::uint64_t tick_hz) noexcept { tick_hz_ = tick_hz; }
  // Where ChunkTimestamp and ChunkExposureTime lie in a multipart buffer's chunk part, from the
  // device's parsed GenICam (at open, on the thread that opened it).
  void set_part_layout(ArvDevice* device);
  Values read(ArvCamera* camera, ArvBuffer* buffer);
  void reset();  // the camera was closed: its XML may differ after a reopen

 private:
  Values read_chunk_part(ArvBuffer* buffer);
  Nanos ticks_to_ns(std::int64_t ticks) const noexcept;

  ArvChunkParser* parser_ = nullptr;
  ResolvedChunkField part_timestamp_, part_exposure_;
  bool part_warned_ = false;  // a chunk part with a field that could not be resolved: said once
  std::uint64_t tick_hz_ = 0;
  bool has_timestamp_ = true, has_exposure_ = true;  // cleared at the first buffer that lacks them
};

}  // namespace sensor_rig::camera::detail
