#pragma once
// Chunk compression: lz4 in the LZ4 frame format (what MCAP readers expect) and zstd (one frame).
#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include "sensor_rig/record/mcap_types.hpp"

namespace sensor_rig::record {

class Compressor {
 public:
  explicit Compressor(Compression c, int zstd_level = 1);
  ~Compressor();
  Compressor(const Compressor&) = delete;
  Compressor& operator=(const Compressor&) = delete;
  // Compresses `in` into `out` (resized). Throws McapError with the library's reason.
  void compress(std::span<const std::byte> in, std::vector<std::byte>& out);

 private:
  Compression c_;
  int level_;
  void* zstd_ = nullptr;  // ZSTD_CCtx
};

// Decompresses a chunk's records compressed as `name` ("", "lz4", "zstd") into exactly
// `uncompressed_size` bytes. Throws McapError naming what went wrong.
void decompress(std::string_view name, std::span<const std::byte> in, std::size_t uncompressed_size,
                std::vector<std::byte>& out);

}  // namespace sensor_rig::record
