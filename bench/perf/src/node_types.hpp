#pragma once
// The perf message types registered with the DDS wrapper, and uniform header access.
// PointCloud2 is the LIDAR driver's message: its id travels in header.frame_id ("perf/<pub>/<seq>").
#include <charconv>
#include <cinttypes>
#include <cstdio>
#include <string_view>
#include <system_error>
#include <type_traits>

#include "sensor_rig/dds/cdr_view.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig_perf.h"

namespace sensor_rig::bench::perf {
using PerfSeq = sensor_rig_msgs_msg_dds__PerfSeq_;
using PerfFixed0 = sensor_rig_msgs_msg_dds__PerfFixed0_;
using PerfFixed16 = sensor_rig_msgs_msg_dds__PerfFixed16_;
using PerfFixed64k = sensor_rig_msgs_msg_dds__PerfFixed64k_;
using PerfFixed512k = sensor_rig_msgs_msg_dds__PerfFixed512k_;
using PerfFixed1m = sensor_rig_msgs_msg_dds__PerfFixed1m_;
using PerfFixed2m = sensor_rig_msgs_msg_dds__PerfFixed2m_;

static_assert(sizeof(PerfFixed16::data) == 16);
static_assert(sizeof(PerfFixed64k::data) == 65536);
static_assert(sizeof(PerfFixed512k::data) == 524288);
static_assert(sizeof(PerfFixed1m::data) == 1048576);
static_assert(sizeof(PerfFixed2m::data) == 2097152);

using PointCloud2 = msg::PointCloud2;

// header.frame_id of a perf PointCloud2: "perf/<publisher>/<seq>" (room for two 10-digit numbers).
inline constexpr std::size_t kCloudFrameIdSize = 32;
inline constexpr std::uint32_t kBadId = 0xffffffffu;  // an id that could not be read: never a sent seq

struct PerfStamp {
  std::uint32_t publisher = 0;
  std::uint32_t seq = 0;
  Nanos stamp_ns = 0;
};

template <class T>
inline PerfStamp read_stamp(const T& s) {
  if constexpr (std::is_same_v<T, PointCloud2>) {
    PerfStamp st{kBadId, kBadId, msg::from_time(s.header.stamp)};
    char tail = 0;
    if (s.header.frame_id == nullptr ||
        std::sscanf(s.header.frame_id, "perf/%" SCNu32 "/%" SCNu32 "%c", &st.publisher, &st.seq, &tail) != 2) {
      st.publisher = st.seq = kBadId;
    }
    return st;
  } else if constexpr (std::is_same_v<T, PerfSeq>) {
    return {s.publisher, s.seq, msg::from_time(s.header.stamp)};
  } else {
    return {s.header.publisher, s.header.seq, msg::from_time(s.header.stamp)};
  }
}
// A PointCloud2 read in place (--reader view): the same "perf/<pub>/<seq>" in header.frame_id.
inline PerfStamp read_stamp(const dds::PointCloud2View& v) {
  PerfStamp st{kBadId, kBadId, static_cast<Nanos>(v.header.sec) * 1'000'000'000 + static_cast<Nanos>(v.header.nanosec)};
  auto number = [](std::string_view text, std::uint32_t& out) {
    const auto r = std::from_chars(text.data(), text.data() + text.size(), out);
    return r.ec == std::errc{} && r.ptr == text.data() + text.size();
  };
  std::string_view id = v.header.frame_id;
  if (!id.starts_with("perf/")) return st;
  id.remove_prefix(5);
  const auto slash = id.find('/');
  std::uint32_t pub = 0, seq = 0;
  if (slash == std::string_view::npos || !number(id.substr(0, slash), pub) || !number(id.substr(slash + 1), seq)) {
    return st;
  }
  st.publisher = pub;
  st.seq = seq;
  return st;
}
// PointCloud2: header.frame_id must point at kCloudFrameIdSize writable bytes.
template <class T>
inline void write_ids(T& s, std::uint32_t publisher, std::uint32_t seq) {
  if constexpr (std::is_same_v<T, PointCloud2>) {
    std::snprintf(s.header.frame_id, kCloudFrameIdSize, "perf/%" PRIu32 "/%" PRIu32, publisher, seq);
  } else if constexpr (std::is_same_v<T, PerfSeq>) {
    s.publisher = publisher;
    s.seq = seq;
  } else {
    s.header.publisher = publisher;
    s.header.seq = seq;
  }
}
template <class T>
inline void write_stamp(T& s, Nanos ns) {
  s.header.stamp = msg::to_time(ns);
}

}  // namespace sensor_rig::bench::perf

RIG_DDS_TYPE(sensor_rig::bench::perf::PerfSeq, sensor_rig_msgs_msg_dds__PerfSeq__desc);
RIG_DDS_TYPE(sensor_rig::bench::perf::PerfFixed0, sensor_rig_msgs_msg_dds__PerfFixed0__desc);
RIG_DDS_TYPE(sensor_rig::bench::perf::PerfFixed16, sensor_rig_msgs_msg_dds__PerfFixed16__desc);
RIG_DDS_TYPE(sensor_rig::bench::perf::PerfFixed64k, sensor_rig_msgs_msg_dds__PerfFixed64k__desc);
RIG_DDS_TYPE(sensor_rig::bench::perf::PerfFixed512k, sensor_rig_msgs_msg_dds__PerfFixed512k__desc);
RIG_DDS_TYPE(sensor_rig::bench::perf::PerfFixed1m, sensor_rig_msgs_msg_dds__PerfFixed1m__desc);
RIG_DDS_TYPE(sensor_rig::bench::perf::PerfFixed2m, sensor_rig_msgs_msg_dds__PerfFixed2m__desc);
