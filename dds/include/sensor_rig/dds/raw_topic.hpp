#pragma once
// Topics read and written as CDR bytes, for any registered type (type_registry.hpp): `rig record`
// keeps samples as they arrived (no decode, no re-encode) and `rig play` publishes them again.
//
// RawReader hands out each sample as rosbag2 stores it: the 4-byte encapsulation header, then the
// members. Over the network that is the serdata's buffer, one piece, no copy. Over shared memory the
// iceoryx chunk holds only the members (in the writer's = this host's byte order): the sample is two
// pieces, a header made here and the chunk itself, still no copy. The bytes stay valid while the
// RawSample holds them (it holds Cyclone's reference, and so the chunk).
//
// RawWriter turns given CDR bytes back into a serdata of the topic's sertype
// (ddsi_serdata_from_ser_iov) and writes it with dds_forwardcdr, so the source timestamp is the one
// given. Cyclone checks the bytes against the type when it deserializes them for a local reader;
// remote readers get them as they are. Over shared memory Cyclone 0.10.2 would not put such a
// serdata into a chunk, so there the bytes are deserialized and written as a sample (one decode).
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dds/entity.hpp"
#include "sensor_rig/dds/participant.hpp"
#include "sensor_rig/dds/qos.hpp"
#include "sensor_rig/dds/type_registry.hpp"
#include "sensor_rig/dds/view_reader.hpp"

struct ddsi_sertype;

namespace sensor_rig::dds {

class RawSample {
 public:
  // The CDR (encapsulation header included) is first() followed by second().
  [[nodiscard]] std::span<const std::byte> first() const noexcept {
    return chunk_ ? std::span<const std::byte>(header_) : whole_;
  }
  [[nodiscard]] std::span<const std::byte> second() const noexcept {
    return chunk_ ? whole_ : std::span<const std::byte>{};
  }
  [[nodiscard]] std::size_t size() const noexcept { return first().size() + second().size(); }
  [[nodiscard]] bool in_shared_memory() const noexcept { return chunk_; }
  [[nodiscard]] std::vector<std::byte> copy() const;
  // The writer's source timestamp (dds_sample_info_t::source_timestamp), vehicle time ns.
  [[nodiscard]] Nanos source_ts() const noexcept { return source_ts_; }
  // CLOCK_REALTIME when the sample was taken (Cyclone 0.10's sample info has no reception time).
  [[nodiscard]] Nanos receive_ts() const noexcept { return receive_ts_; }
  void reset() noexcept;

 private:
  friend class RawReader;
  SerializedSample held_;
  std::array<std::byte, 4> header_{};
  std::span<const std::byte> whole_;
  bool chunk_ = false;
  Nanos source_ts_ = 0;
  Nanos receive_ts_ = 0;
};

class RawReader {
 public:
  // A reader of DDS topic `dds_topic` ("rt/...") of `type` (which must outlive the reader: the
  // registry's entries do). Throws DdsError.
  RawReader(const Participant& p, const std::string& dds_topic, const RegisteredType& type, const QosSpec& qos);
  // The next sample into `out`; false when none is left. A sample whose bytes are not XCDR1 CDR
  // is counted (malformed()) and skipped.
  bool take(RawSample& out) noexcept;
  [[nodiscard]] dds_entity_t handle() const noexcept { return reader_.handle(); }
  [[nodiscard]] const std::string& dds_topic() const noexcept { return dds_topic_; }
  [[nodiscard]] const RegisteredType& type() const noexcept { return *type_; }
  [[nodiscard]] std::uint64_t malformed() const noexcept { return malformed_; }
  // Samples DDS reports lost (SAMPLE_LOST) and rejected (SAMPLE_REJECTED) for this reader so far.
  [[nodiscard]] std::uint64_t lost() const noexcept { return lost_; }
  [[nodiscard]] std::uint64_t rejected() const noexcept { return rejected_; }
  // Reads both statuses into lost()/rejected(); call now and then (not per sample).
  void update_status() noexcept;

 private:
  std::string dds_topic_;
  const RegisteredType* type_;
  Entity topic_;
  Entity reader_;
  std::uint64_t malformed_ = 0;
  std::uint64_t lost_ = 0;
  std::uint64_t rejected_ = 0;
};

class RawWriter {
 public:
  // A writer of DDS topic `dds_topic` of `type` (which must outlive the writer). Throws DdsError.
  RawWriter(const Participant& p, const std::string& dds_topic, const RegisteredType& type, const QosSpec& qos);
  // Publishes one sample given as CDR (encapsulation header first), in one or more pieces, with
  // source timestamp `source_ts` (vehicle ns). Not ok: the bytes are shorter than a header
  // (BAD_PARAMETER) or Cyclone refused the write (e.g. a reliable reader's queue stayed full).
  Result write(std::span<const std::span<const std::byte>> pieces, Nanos source_ts) noexcept;
  Result write(std::span<const std::byte> cdr, Nanos source_ts) noexcept {
    const std::span<const std::byte> one[] = {cdr};
    return write(one, source_ts);
  }
  [[nodiscard]] std::uint32_t matched() const;
  [[nodiscard]] dds_entity_t handle() const noexcept { return writer_.handle(); }
  [[nodiscard]] const RegisteredType& type() const noexcept { return *type_; }

 private:
  const RegisteredType* type_;
  Entity topic_;
  const ddsi_sertype* sertype_ = nullptr;  // the topic's, valid while topic_ lives
  Entity writer_;
  bool shm_ = false;  // the writer publishes over iceoryx: deserialize and dds_write (raw_topic.cpp)
};

}  // namespace sensor_rig::dds
