#include "compression.hpp"

#include <lz4frame.h>
#include <zstd.h>

#include <cstring>

namespace sensor_rig::record {

std::optional<Compression> parse_compression(std::string_view s) {
  if (s == "none") return Compression::kNone;
  if (s == "lz4") return Compression::kLz4;
  if (s == "zstd") return Compression::kZstd;
  return std::nullopt;
}

std::string_view mcap_name(Compression c) {
  switch (c) {
    case Compression::kLz4: return "lz4";
    case Compression::kZstd: return "zstd";
    case Compression::kNone: break;
  }
  return "";
}

Compressor::Compressor(Compression c, int zstd_level) : c_(c), level_(zstd_level) {
  if (c_ == Compression::kZstd) {
    zstd_ = ZSTD_createCCtx();
    if (zstd_ == nullptr) throw McapError("zstd: cannot create a compression context");
  }
}

Compressor::~Compressor() { ZSTD_freeCCtx(static_cast<ZSTD_CCtx*>(zstd_)); }

void Compressor::compress(std::span<const std::byte> in, std::vector<std::byte>& out) {
  switch (c_) {
    case Compression::kNone:
      out.assign(in.begin(), in.end());
      return;
    case Compression::kLz4: {
      LZ4F_preferences_t prefs{};
      prefs.frameInfo.blockSizeID = LZ4F_max4MB;
      prefs.frameInfo.contentSize = in.size();
      out.resize(LZ4F_compressFrameBound(in.size(), &prefs));
      const std::size_t n = LZ4F_compressFrame(out.data(), out.size(), in.data(), in.size(), &prefs);
      if (LZ4F_isError(n)) throw McapError(std::string("lz4: ") + LZ4F_getErrorName(n));
      out.resize(n);
      return;
    }
    case Compression::kZstd: {
      out.resize(ZSTD_compressBound(in.size()));
      const std::size_t n = ZSTD_compressCCtx(static_cast<ZSTD_CCtx*>(zstd_), out.data(), out.size(), in.data(),
                                              in.size(), level_);
      if (ZSTD_isError(n)) throw McapError(std::string("zstd: ") + ZSTD_getErrorName(n));
      out.resize(n);
      return;
    }
  }
}

void decompress(std::string_view name, std::span<const std::byte> in, std::size_t uncompressed_size,
                std::vector<std::byte>& out) {
  out.resize(uncompressed_size);
  if (name.empty()) {
    if (in.size() != uncompressed_size) throw McapError("uncompressed chunk of " + std::to_string(in.size()) +
                                                        " bytes, its header says " + std::to_string(uncompressed_size));
    if (!in.empty()) std::memcpy(out.data(), in.data(), in.size());
    return;
  }
  if (name == "zstd") {
    const std::size_t n = ZSTD_decompress(out.data(), out.size(), in.data(), in.size());
    if (ZSTD_isError(n)) throw McapError(std::string("zstd: ") + ZSTD_getErrorName(n));
    if (n != uncompressed_size) throw McapError("zstd: " + std::to_string(n) + " bytes out, expected " + std::to_string(uncompressed_size));
    return;
  }
  if (name == "lz4") {
    LZ4F_dctx* dctx = nullptr;
    if (LZ4F_isError(LZ4F_createDecompressionContext(&dctx, LZ4F_VERSION))) throw McapError("lz4: no context");
    std::size_t src_pos = 0, dst_pos = 0, hint = 1;
    std::string err;
    while (hint != 0 && err.empty()) {
      std::size_t src_n = in.size() - src_pos, dst_n = out.size() - dst_pos;
      if (src_n == 0) {
        err = "lz4: frame ends early";
        break;
      }
      hint = LZ4F_decompress(dctx, out.data() + dst_pos, &dst_n, in.data() + src_pos, &src_n, nullptr);
      if (LZ4F_isError(hint)) err = std::string("lz4: ") + LZ4F_getErrorName(hint);
      src_pos += src_n;
      dst_pos += dst_n;
      if (src_n == 0 && dst_n == 0 && hint != 0 && err.empty()) err = "lz4: no progress (output larger than the header says)";
    }
    LZ4F_freeDecompressionContext(dctx);
    if (!err.empty()) throw McapError(err);
    if (dst_pos != uncompressed_size) throw McapError("lz4: " + std::to_string(dst_pos) + " bytes out, expected " + std::to_string(uncompressed_size));
    return;
  }
  throw McapError("unknown compression '" + std::string(name) + "'");
}

}  // namespace sensor_rig::record
