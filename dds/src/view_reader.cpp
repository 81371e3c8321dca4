#include "sensor_rig/dds/view_reader.hpp"

#include <dds/ddsi/ddsi_serdata.h>
#include <dds/ddsi/ddsi_shm_transport.h>

#include <utility>

namespace sensor_rig::dds {
namespace {

// A serialized chunk (shm): the members at the chunk's start, no encapsulation header, in the
// writer's (= this host's) byte order, data_size bytes (Cyclone's fill_iox_chunk).
std::optional<CdrBody> chunk_body(void* chunk) noexcept {
  const iceoryx_header_t* hdr = iceoryx_header_from_chunk(chunk);
  if (hdr->shm_data_state != IOX_CHUNK_CONTAINS_SERIALIZED_DATA) return std::nullopt;
  return CdrBody{{static_cast<const std::byte*>(chunk), hdr->data_size}, std::endian::native};
}

}  // namespace

SerializedSample::SerializedSample(SerializedSample&& o) noexcept
    : serdata_(std::exchange(o.serdata_, nullptr)), ser_ref_(std::exchange(o.ser_ref_, nullptr)),
      ser_ref_base_(o.ser_ref_base_), ser_ref_len_(o.ser_ref_len_), in_chunk_(o.in_chunk_), body_(std::exchange(o.body_, std::nullopt)),
      info_(o.info_) {}

SerializedSample& SerializedSample::operator=(SerializedSample&& o) noexcept {
  if (this != &o) {
    reset();
    serdata_ = std::exchange(o.serdata_, nullptr);
    ser_ref_ = std::exchange(o.ser_ref_, nullptr);
    ser_ref_base_ = o.ser_ref_base_;
    ser_ref_len_ = o.ser_ref_len_;
    in_chunk_ = o.in_chunk_;
    body_ = std::exchange(o.body_, std::nullopt);
    info_ = o.info_;
  }
  return *this;
}

void SerializedSample::reset() noexcept {
  if (ser_ref_ != nullptr) {
    ddsrt_iovec_t ref{};
    ref.iov_base = ser_ref_base_;
    ref.iov_len = static_cast<ddsrt_iov_len_t>(ser_ref_len_);
    ddsi_serdata_to_ser_unref(ser_ref_, &ref);
  }
  ser_ref_ = nullptr;
  if (serdata_ != nullptr) ddsi_serdata_unref(serdata_);  // the last reference returns the chunk
  serdata_ = nullptr;
  body_.reset();
  in_chunk_ = false;
}

bool take_serialized(dds_entity_t reader, SerializedSample& out) noexcept {
  out.reset();
  for (;;) {
    ddsi_serdata* sd = nullptr;
    dds_sample_info_t info{};
    if (dds_takecdr(reader, &sd, 1, &info, DDS_ANY_STATE) <= 0 || sd == nullptr) return false;
    if (!info.valid_data) {
      ddsi_serdata_unref(sd);
      continue;
    }
    out.serdata_ = sd;
    out.info_ = info;
    if (sd->iox_chunk != nullptr) {
      out.in_chunk_ = true;
      out.body_ = chunk_body(sd->iox_chunk);
    } else {
      // The whole serialized sample, encapsulation header first, held until reset() (Cyclone's
      // default serdata keeps it contiguous and only takes another reference).
      ddsrt_iovec_t ref{};
      out.ser_ref_ = ddsi_serdata_to_ser_ref(sd, 0, ddsi_serdata_size(sd), &ref);
      out.ser_ref_base_ = ref.iov_base;
      out.ser_ref_len_ = ref.iov_len;
      out.body_ = cdr_body({static_cast<const std::byte*>(ref.iov_base), ref.iov_len});
    }
    return true;
  }
}

}  // namespace sensor_rig::dds
