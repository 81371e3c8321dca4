#include "sensor_rig/dds/raw_topic.hpp"

#include <dds/ddsc/dds_loan_api.h>
#include <dds/ddsi/ddsi_serdata.h>

#include <bit>
#include <vector>

#include "sensor_rig/dds/payload_sertype.h"
#include "sensor_rig/dds/topic.hpp"

namespace sensor_rig::dds {

std::vector<std::byte> RawSample::copy() const {
  std::vector<std::byte> out(first().begin(), first().end());
  out.insert(out.end(), second().begin(), second().end());
  return out;
}

void RawSample::reset() noexcept {
  held_.reset();
  whole_ = {};
  chunk_ = false;
  source_ts_ = receive_ts_ = 0;
}

RawReader::RawReader(const Participant& p, const std::string& dds_topic, const RegisteredType& type,
                     const QosSpec& qos)
    : dds_topic_(dds_topic), type_(&type) {
  topic_ = Entity(check(dds_create_topic(p.handle(), type.descriptor, dds_topic.c_str(), nullptr, nullptr),
                        "dds_create_topic"));
  auto q = make_qos(qos);
  reader_ = Entity(check(dds_create_reader(p.handle(), topic_.handle(), q.get(), nullptr), "dds_create_reader"));
}

bool RawReader::take(RawSample& out) noexcept {
  out.reset();
  while (take_serialized(reader_.handle(), out.held_)) {
    const auto body = out.held_.body();
    if (!body) {
      ++malformed_;
      continue;
    }
    out.receive_ts_ = vehicle_now_ns();
    out.source_ts_ = out.held_.info().source_timestamp;
    if (out.held_.in_shared_memory()) {
      // CDR_LE / CDR_BE, options 0: the chunk's members are in this host's order (view_reader.cpp).
      out.chunk_ = true;
      out.header_ = {std::byte{0}, body->order == std::endian::little ? std::byte{1} : std::byte{0}, std::byte{0}, std::byte{0}};
      out.whole_ = body->body;
    } else {
      // cdr_body() is the serdata's buffer past its 4-byte header: the header is right before it.
      out.whole_ = {body->body.data() - 4, body->body.size() + 4};
    }
    return true;
  }
  out.reset();
  return false;
}

void RawReader::update_status() noexcept {
  dds_sample_lost_status_t lost{};
  if (dds_get_sample_lost_status(reader_.handle(), &lost) >= 0) lost_ = lost.total_count;
  dds_sample_rejected_status_t rejected{};
  if (dds_get_sample_rejected_status(reader_.handle(), &rejected) >= 0) rejected_ = rejected.total_count;
}

RawWriter::RawWriter(const Participant& p, const std::string& dds_topic, const RegisteredType& type,
                     const QosSpec& qos)
    : type_(&type) {
  topic_ = Entity(check(rig_create_cdr_topic(p.handle(), type.descriptor, dds_topic.c_str(), nullptr, &sertype_),
                        "rig_create_cdr_topic"));
  auto q = make_qos(qos);
  writer_ = Entity(check(dds_create_writer(p.handle(), topic_.handle(), q.get(), nullptr), "dds_create_writer"));
  shm_ = dds_is_shared_memory_available(writer_.handle());
}

Result RawWriter::write(std::span<const std::span<const std::byte>> pieces, Nanos source_ts) noexcept {
  constexpr std::size_t kMaxPieces = 8;
  if (pieces.size() > kMaxPieces) return Result(DDS_RETCODE_BAD_PARAMETER);
  ddsrt_iovec_t iov[kMaxPieces];
  std::size_t size = 0;
  for (std::size_t i = 0; i < pieces.size(); ++i) {
    iov[i].iov_base = const_cast<std::byte*>(pieces[i].data());  // read only: from_ser_iov copies
    iov[i].iov_len = static_cast<ddsrt_iov_len_t>(pieces[i].size());
    size += pieces[i].size();
  }
  if (size < 4) return Result(DDS_RETCODE_BAD_PARAMETER);
  ddsi_serdata* sd = ddsi_serdata_from_ser_iov(sertype_, SDK_DATA, static_cast<ddsrt_msg_iovlen_t>(pieces.size()), iov, size);
  if (sd == nullptr) return Result(DDS_RETCODE_BAD_PARAMETER);
  if (shm_) {
    // Cyclone 0.10.2's dds_forwardcdr does not put a serdata without an iceoryx chunk into shared
    // memory (its shm readers never get it): over shm the sample is deserialized and written as
    // one, and Cyclone serializes it into a chunk itself.
    void* sample = dds_alloc(type_->descriptor->m_size);
    const bool ok = ddsi_serdata_to_sample(sd, sample, nullptr, nullptr);
    ddsi_serdata_unref(sd);
    const dds_return_t rc = ok ? dds_write_ts(writer_.handle(), sample, static_cast<dds_time_t>(source_ts))
                               : DDS_RETCODE_BAD_PARAMETER;
    dds_sample_free(sample, type_->descriptor, DDS_FREE_ALL);
    return Result(rc);
  }
  sd->statusinfo = 0;
  sd->timestamp.v = static_cast<dds_time_t>(source_ts);
  return Result(dds_forwardcdr(writer_.handle(), sd));  // consumes sd's reference
}

std::uint32_t RawWriter::matched() const { return publication_matched(writer_.handle()); }

}  // namespace sensor_rig::dds
