#pragma once
// What a reader's DDS says it lost: samples it knows were published and it will never deliver
// (SAMPLE_LOST: a gap the writer declared, e.g. a sample dropped from a keep-last history before
// this reader had it) plus samples refused for lack of resources (SAMPLE_REJECTED). A keep-last
// reader that overwrites samples not yet taken reports neither.
#include <dds/dds.h>

#include <cstdint>

namespace sensor_rig::dds {

inline std::uint64_t reader_samples_lost(dds_entity_t reader) noexcept {
  std::uint64_t n = 0;
  dds_sample_lost_status_t lost{};
  if (dds_get_sample_lost_status(reader, &lost) >= 0) n += lost.total_count;
  dds_sample_rejected_status_t rejected{};
  if (dds_get_sample_rejected_status(reader, &rejected) >= 0) n += rejected.total_count;
  return n;
}

}  // namespace sensor_rig::dds
