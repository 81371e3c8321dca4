#pragma once
// The hot loop's pixel field read: one unaligned 8-byte load instead of FieldReader's byte loop
// (whose runtime length keeps the compiler from unrolling it). The load is the 8 bytes that END
// at the field's last byte, so it never reads past the pixel; it may start up to 7 bytes before
// the pixel, which is inside the packet because every pixel follows a column header of at least 8
// bytes (12 or 16: kMinBytesBefore). constexpr, so that a reader built from the profile table at
// compile time folds into constant shifts and masks. Big-endian hosts read byte by byte.
#include <bit>
#include <cstdint>
#include <cstring>

#include "sensor_rig/lidar/ouster/profile.hpp"

namespace sensor_rig::lidar::ouster {

class PixelReader {
 public:
  static constexpr int kMinBytesBefore = 8;  // readable bytes the decoder guarantees before a pixel

  constexpr PixelReader() = default;
  constexpr explicit PixelReader(const FieldSpec& f) noexcept
      : byte_offset_(f.bit_offset / 8),
        nbytes_((f.bit_offset % 8 + f.width + 7) / 8),
        bit_shift_(f.bit_offset % 8),
        upshift_(f.upshift),
        mask_(f.width == 0 ? 0 : (std::uint64_t{1} << f.width) - 1),  // widths are <= 32 (profile table)
        load_offset_(byte_offset_ + nbytes_ - 8),
        load_shift_(nbytes_ == 0 ? 0 : bit_shift_ + 8 * (8 - nbytes_)) {}  // an absent field reads 0

  // `px`: a pixel of a packet that passed check_packet().
  [[nodiscard]] std::uint64_t read(const std::uint8_t* px) const noexcept {
    std::uint64_t w = 0;
    if constexpr (std::endian::native == std::endian::little) {
      std::memcpy(&w, px + load_offset_, sizeof w);
      return ((w >> load_shift_) & mask_) << upshift_;
    } else {
      for (int i = 0; i < nbytes_; ++i) w |= static_cast<std::uint64_t>(px[byte_offset_ + i]) << (8 * i);
      return ((w >> bit_shift_) & mask_) << upshift_;
    }
  }

 private:
  int byte_offset_ = 0;
  int nbytes_ = 0;
  int bit_shift_ = 0;
  int upshift_ = 0;
  std::uint64_t mask_ = 0;
  int load_offset_ = -8;
  int load_shift_ = 0;
};

}  // namespace sensor_rig::lidar::ouster
