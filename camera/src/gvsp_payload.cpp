#include "gvsp_payload.hpp"

#include <algorithm>
#include <cmath>

#include "sensor_rig/common/log.hpp"

namespace sensor_rig::camera::detail {
namespace {

// Rows of `row` bytes `step` apart fit in `bytes` (the last row's padding may be absent).
bool fits(std::size_t bytes, std::uint32_t row, std::uint32_t step, std::uint32_t height) noexcept {
  return height > 0 && step >= row && bytes >= std::size_t{step} * (height - 1) + row;
}

LocatedImage from_region(ArvBuffer* b, const void* base, const void* image, std::size_t image_bytes, std::uint32_t row,
                         std::uint32_t x_padding, std::uint32_t height) {
  LocatedImage r;
  if (image == nullptr || base == nullptr || image < base) {
    r.error = "no image data";
    return r;
  }
  r.offset = static_cast<std::size_t>(static_cast<const std::uint8_t*>(image) - static_cast<const std::uint8_t*>(base));
  r.step = row + x_padding;
  if (!fits(image_bytes, row, r.step, height))
    r.error = "image of " + std::to_string(image_bytes) + " bytes for " + std::to_string(height) + " rows of " +
              std::to_string(r.step) + " (frame " + std::to_string(arv_buffer_get_frame_id(b)) + ")";
  return r;
}

}  // namespace

std::size_t first_chunk_bytes(const std::uint8_t* data, std::size_t size) {
  std::size_t bytes = 0;
  walk_chunks(data, size, [&](std::uint32_t, ChunkSpan chunk) {
    if (chunk.data == data) bytes = chunk.size;  // this chunk starts the buffer: the image
    return chunk.data == data;
  });
  return bytes;
}

const char* payload_name(ArvBuffer* b) {
  switch (arv_buffer_get_payload_type(b)) {
    case ARV_BUFFER_PAYLOAD_TYPE_IMAGE: return arv_buffer_has_chunks(b) != FALSE ? "image+chunks" : "image";
    case ARV_BUFFER_PAYLOAD_TYPE_CHUNK_DATA: return "chunk_data";
    case ARV_BUFFER_PAYLOAD_TYPE_EXTENDED_CHUNK_DATA: return "extended_chunk_data";
    case ARV_BUFFER_PAYLOAD_TYPE_MULTIPART: return "multipart";
    default: return "other";
  }
}

LocatedImage locate_image(ArvBuffer* b, std::uint32_t width, std::uint32_t height, PixelFormat format) {
  const std::uint32_t row = row_step(format, width);
  std::size_t size = 0;
  const void* base = arv_buffer_get_data(b, &size);
  const auto type = arv_buffer_get_payload_type(b);
  LocatedImage r;
  switch (type) {
    case ARV_BUFFER_PAYLOAD_TYPE_IMAGE:  // also image + chunks (0x4001): Aravis keeps the chunk flag apart
    case ARV_BUFFER_PAYLOAD_TYPE_EXTENDED_CHUNK_DATA: {
      if (static_cast<std::uint32_t>(arv_buffer_get_image_width(b)) != width ||
          static_cast<std::uint32_t>(arv_buffer_get_image_height(b)) != height) {
        r.error = "image " + std::to_string(arv_buffer_get_image_width(b)) + "x" + std::to_string(arv_buffer_get_image_height(b));
        return r;
      }
      gint x_padding = 0, y_padding = 0;
      arv_buffer_get_image_padding(b, &x_padding, &y_padding);
      std::size_t image_bytes = 0;
      const void* image = arv_buffer_get_image_data(b, &image_bytes);
      return from_region(b, base, image, image_bytes, row, static_cast<std::uint32_t>(std::max(x_padding, 0)), height);
    }
    case ARV_BUFFER_PAYLOAD_TYPE_CHUNK_DATA: {  // no image infos: the image is the first chunk
      const std::size_t bytes = base != nullptr ? first_chunk_bytes(static_cast<const std::uint8_t*>(base), size) : 0;
      const std::uint32_t padding = bytes % height == 0 && bytes / height >= row ? static_cast<std::uint32_t>(bytes / height) - row : 0;
      return from_region(b, base, base, bytes, row, padding, height);
    }
    case ARV_BUFFER_PAYLOAD_TYPE_MULTIPART:
      for (guint part = 0; part < arv_buffer_get_n_parts(b); ++part) {
        if (arv_buffer_get_part_data_type(b, part) != ARV_BUFFER_PART_DATA_TYPE_2D_IMAGE ||
            static_cast<std::uint32_t>(arv_buffer_get_part_width(b, part)) != width ||
            static_cast<std::uint32_t>(arv_buffer_get_part_height(b, part)) != height)
          continue;
        gint x_padding = 0, y_padding = 0;
        arv_buffer_get_part_padding(b, part, &x_padding, &y_padding);
        std::size_t part_bytes = 0;
        const void* image = arv_buffer_get_part_data(b, part, &part_bytes);
        return from_region(b, base, image, part_bytes, row, static_cast<std::uint32_t>(std::max(x_padding, 0)), height);
      }
      r.error = "multipart without a " + std::to_string(width) + "x" + std::to_string(height) + " image part";
      return r;
    default:
      r.error = "payload type " + std::to_string(static_cast<int>(type));
      return r;
  }
}

std::uint64_t timestamp_tick_hz(ArvDevice* device) {
  if (device == nullptr || arv_device_is_feature_available(device, "GevTimestampTickFrequency", nullptr) == FALSE) return 0;
  GError* err = nullptr;
  const gint64 hz = arv_device_get_integer_feature_value(device, "GevTimestampTickFrequency", &err);
  if (err != nullptr) {
    g_clear_error(&err);
    return 0;
  }
  return hz > 0 ? static_cast<std::uint64_t>(hz) : 0;
}

ChunkReader::~ChunkReader() { reset(); }

void ChunkReader::reset() {
  if (parser_ != nullptr) g_object_unref(parser_);
  parser_ = nullptr;
  has_timestamp_ = has_exposure_ = true;
}

void ChunkReader::set_part_layout(ArvDevice* device) {
  ArvGc* gc = device != nullptr ? arv_device_get_genicam(device) : nullptr;
  part_timestamp_ = resolve_chunk_field(gc, "ChunkTimestamp");
  part_exposure_ = resolve_chunk_field(gc, "ChunkExposureTime");
  part_warned_ = false;
}

Nanos ChunkReader::ticks_to_ns(std::int64_t ticks) const noexcept {
  if (tick_hz_ == 0 || tick_hz_ == 1'000'000'000) return ticks;
  return static_cast<Nanos>(static_cast<double>(ticks) * 1e9 / static_cast<double>(tick_hz_));
}

ChunkReader::Values ChunkReader::read_chunk_part(ArvBuffer* buffer) {
  Values v;
  for (guint part = 0; part < arv_buffer_get_n_parts(buffer); ++part) {
    if (arv_buffer_get_part_data_type(buffer, part) != ARV_BUFFER_PART_DATA_TYPE_CHUNK_DATA) continue;
    std::size_t size = 0;
    const auto* data = static_cast<const std::uint8_t*>(arv_buffer_get_part_data(buffer, part, &size));
    if (!part_warned_ && (!part_timestamp_.field || !part_exposure_.field)) {
      part_warned_ = true;
      log::warn("camera", "multipart chunk values: " + (part_timestamp_.field ? part_exposure_.why_not : part_timestamp_.why_not) +
                              " (the exposure is then read over GVCP)");
    }
    const auto* ts = part_timestamp_.field ? &*part_timestamp_.field : nullptr;
    const auto* ex = part_exposure_.field ? &*part_exposure_.field : nullptr;
    if (const auto chunk = ts != nullptr ? find_chunk(data, size, ts->chunk_id) : std::nullopt)
      if (const auto ticks = read_integer(*chunk, *ts)) v.timestamp_ns = ticks_to_ns(*ticks);
    if (const auto chunk = ex != nullptr ? find_chunk(data, size, ex->chunk_id) : std::nullopt)
      if (const auto us = read_float(*chunk, *ex); us && *us > 0 && std::isfinite(*us)) v.exposure_ns = static_cast<Nanos>(std::llround(*us * 1000.0));
    break;  // one chunk part per buffer
  }
  return v;
}

ChunkReader::Values ChunkReader::read(ArvCamera* camera, ArvBuffer* buffer) {
  if (arv_buffer_get_payload_type(buffer) == ARV_BUFFER_PAYLOAD_TYPE_MULTIPART) return read_chunk_part(buffer);
  Values v;
  if (!arv_buffer_has_chunks(buffer) || (!has_timestamp_ && !has_exposure_)) return v;
  if (parser_ == nullptr) {
    std::lock_guard one_parse_at_a_time(genicam_parse_mutex());
    parser_ = arv_camera_create_chunk_parser(camera);
  }
  if (parser_ == nullptr) {
    has_timestamp_ = has_exposure_ = false;
    return v;
  }
  GError* err = nullptr;
  if (has_timestamp_) {
    const gint64 ticks = arv_chunk_parser_get_integer_value(parser_, buffer, "ChunkTimestamp", &err);
    if (err != nullptr) {  // a camera without it: not asked again (each miss is a GLib warning)
      g_clear_error(&err);
      has_timestamp_ = false;
    } else {
      v.timestamp_ns = ticks_to_ns(ticks);
    }
  }
  if (has_exposure_) {  // SFNC: a Float in us; some cameras an Integer
    double us = arv_chunk_parser_get_float_value(parser_, buffer, "ChunkExposureTime", &err);
    if (err != nullptr && g_error_matches(err, ARV_CHUNK_PARSER_ERROR, ARV_CHUNK_PARSER_ERROR_INVALID_FEATURE_TYPE)) {
      g_clear_error(&err);
      us = static_cast<double>(arv_chunk_parser_get_integer_value(parser_, buffer, "ChunkExposureTime", &err));
    }
    if (err != nullptr) {
      g_clear_error(&err);
      has_exposure_ = false;
    } else if (us > 0 && std::isfinite(us)) {
      v.exposure_ns = static_cast<Nanos>(std::llround(us * 1000.0));
    }
  }
  return v;
}

std::mutex& genicam_parse_mutex() {
  static std::mutex m;
  return m;
}

}  // namespace sensor_rig::camera::detail
