#pragma once
// Zero-copy reading of PointCloud2 / Image: take the serialized sample (dds_takecdr) and read a
// validated view of it (cdr_view.hpp) instead of deserializing `data` into a fresh buffer.
// Over shared memory the view points into the iceoryx chunk itself (Cyclone 0.10.2 serializes
// variable-size types into the chunk and hands the reader a serdata that references it); over the
// network, into the serdata's reassembled buffer. The view is valid while its SerializedSample
// lives: that holds the serdata (and so the chunk) and releases it when it goes.
#include <cstddef>
#include <cstdint>
#include <optional>

#include "sensor_rig/dds/cdr_view.hpp"
#include "sensor_rig/dds/entity.hpp"

struct ddsi_serdata;

namespace sensor_rig::dds {

// One taken sample in serialized form; move-only owner of Cyclone's reference.
class SerializedSample {
 public:
  SerializedSample() = default;
  SerializedSample(const SerializedSample&) = delete;
  SerializedSample& operator=(const SerializedSample&) = delete;
  SerializedSample(SerializedSample&& o) noexcept;
  SerializedSample& operator=(SerializedSample&& o) noexcept;
  ~SerializedSample() { reset(); }

  // The serialized members, wherever they are; nullopt when not XCDR1 CDR (counted as malformed).
  [[nodiscard]] std::optional<CdrBody> body() const noexcept { return body_; }
  [[nodiscard]] bool in_shared_memory() const noexcept { return in_chunk_; }
  [[nodiscard]] const dds_sample_info_t& info() const noexcept { return info_; }
  void reset() noexcept;

 private:
  friend bool take_serialized(dds_entity_t reader, SerializedSample& out) noexcept;
  ddsi_serdata* serdata_ = nullptr;  // from dds_takecdr
  ddsi_serdata* ser_ref_ = nullptr;  // network: to_ser_ref's hold on the bytes, released first
  void* ser_ref_base_ = nullptr;
  std::size_t ser_ref_len_ = 0;
  bool in_chunk_ = false;
  std::optional<CdrBody> body_;
  dds_sample_info_t info_{};
};

// Takes the next sample with data (skipping disposes and the like) into `out`; false when none.
bool take_serialized(dds_entity_t reader, SerializedSample& out) noexcept;

struct ViewCounts {
  std::uint64_t in_chunk = 0;    // viewed in place in the iceoryx chunk
  std::uint64_t in_serdata = 0;  // viewed in the serdata's buffer (network)
  std::uint64_t malformed = 0;   // dropped: the bytes did not parse
  CdrStatus last_error = CdrStatus::kOk;
};

// The next sample parsed into `view`; false when none is left. Malformed samples are counted in
// `counts` and skipped. `view` is valid while `sample` holds this sample.
template <class View>
bool take_view(dds_entity_t reader, SerializedSample& sample, View& view, ViewCounts& counts) noexcept {
  while (take_serialized(reader, sample)) {
    const auto body = sample.body();
    const CdrStatus st = body ? parse_cdr(*body, view) : CdrStatus::kBadEncapsulation;
    if (st == CdrStatus::kOk) {
      ++(sample.in_shared_memory() ? counts.in_chunk : counts.in_serdata);
      return true;
    }
    ++counts.malformed;
    counts.last_error = st;
  }
  sample.reset();
  return false;
}

// Takes up to `max` samples and calls fn(const View&, const dds_sample_info_t&) for each one that
// parses; the view is valid during the call. Returns how many were passed to fn.
template <class View, class F>
int take_views(dds_entity_t reader, View& view, ViewCounts& counts, F&& fn, int max = 256) {
  SerializedSample sample;
  int n = 0;
  while (n < max && take_view(reader, sample, view, counts)) {
    fn(static_cast<const View&>(view), sample.info());
    ++n;
  }
  return n;
}

}  // namespace sensor_rig::dds
