#pragma once
// rig-fake-gige-camera: the GVSP (GigE Vision stream) datagram facts its tools read and rewrite. A
// standard (not extended-id) header: status (2), block id (2), packet infos (4: the content type in
// the top byte, the packet id below it).
#include <cstddef>
#include <cstdint>

namespace sensor_rig::camera::mock::gvsp {

inline constexpr std::size_t kHeader = 8;
inline constexpr std::size_t kContentTypeOffset = 4;
// Content types.
inline constexpr std::uint8_t kLeader = 1, kTrailer = 2, kPayload = 3;

}  // namespace sensor_rig::camera::mock::gvsp
