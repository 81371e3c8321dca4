#pragma once
// The chunk values of a multipart buffer (issue 27 items 3 and 9). Aravis 0.8's chunk parser reads
// chunks only from the end of an image or chunk-data buffer; a GigE Vision 2.1 multipart buffer
// carries them in a part of their own (data type 0x000A) that the parser never reaches, so every
// multipart frame fell back to the GVCP exposure read and had no chunk timestamp. Here the rig
// locates the features' chunks itself: each field's chunk id, offset, length, byte order and type
// are taken once, at open, from the camera's GenICam nodes as Aravis parsed them (the register's
// Address, Length, Endianess and Sign; its Port's ChunkID), and the chunk part is walked as the
// GenICam chunk layout has it (each chunk's data, then its id and length, big endian; from the end).
#include <arv.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

namespace sensor_rig::camera::detail {

// Where one chunk feature's value lies: in chunk `chunk_id`, `offset` bytes into its data.
struct ChunkField {
  std::uint32_t chunk_id = 0;
  std::uint64_t offset = 0;  // the register's Address
  std::uint32_t length = 0;  // bytes: 1..8 (a FloatReg 4 or 8)
  bool big_endian = false;   // GenICam's default byte order is little endian
  bool is_float = false;     // FloatReg: IEEE 754
  bool is_signed = false;    // IntReg Sign (default Unsigned)
  bool operator==(const ChunkField&) const = default;
};

// One chunk's data.
struct ChunkSpan {
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
};

// The chunks of `data[0, size)` from the last to the first: `visit(id, span)` until it returns
// true. Stops, unvisited, where the tags do not add up (a corrupt part is not read at a guessed
// place). One walk for the image chunk of a chunk-data buffer and the values of a chunk part.
template <class Visit>
void walk_chunks(const std::uint8_t* data, std::size_t size, Visit&& visit) {
  constexpr std::size_t kTag = 8;  // id, length
  if (data == nullptr) return;
  const auto be32 = [](const std::uint8_t* p) {
    return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
  };
  for (std::size_t end = size; end >= kTag;) {  // one past the current chunk's tag
    const std::size_t tag = end - kTag;
    const std::size_t length = be32(data + end - 4);
    if (length > tag) return;
    if (visit(be32(data + tag), ChunkSpan{data + tag - length, length})) return;
    end = tag - length;
  }
}

// The data of the chunk with `id`; nullopt when it is not there or the tags do not add up.
std::optional<ChunkSpan> find_chunk(const std::uint8_t* data, std::size_t size, std::uint32_t id);

// The field's value in its chunk; nullopt when its bytes lie outside the chunk's data.
// read_integer rounds a float field; read_float widens an integer one.
std::optional<std::int64_t> read_integer(const ChunkSpan& chunk, const ChunkField& field);
std::optional<double> read_float(const ChunkSpan& chunk, const ChunkField& field);

// `feature` of the camera's parsed GenICam (`gc`, from arv_device_get_genicam) as a chunk field:
// the node, followed through pValue to the IntReg/FloatReg that holds it, whose pPort is a Port
// with a ChunkID. No device I/O for a constant Address and Length (a chunk register's are).
// `why_not` says what is missing when `field` is empty (absent, not a plain register, no ChunkID).
struct ResolvedChunkField {
  std::optional<ChunkField> field;
  std::string why_not;
};
ResolvedChunkField resolve_chunk_field(ArvGc* gc, const char* feature);

}  // namespace sensor_rig::camera::detail
