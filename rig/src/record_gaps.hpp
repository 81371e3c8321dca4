#pragma once
// `rig record`: samples the rig announced on /rig/stamps that never reached the recorder. DDS does
// not say (Cyclone 0.10 reports no SAMPLE_LOST when a reliable keep-last writer drops samples a
// slow reader had not acknowledged: a recorder stopped 2.5 s missed 8-25 samples per topic and
// counted 0, tests/record/record_monitor_counts_test.cpp). The drivers announce every sample they
// write (topic, header stamp), as `rig monitor` uses them: a sample announced and not received
// within the timeout is counted missed on its topic. Pure bookkeeping: no DDS, no I/O.
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::rig {

namespace record_cdr {

// A primitive at `off` (XCDR1: aligned to its size relative to the body) in the body's byte order.
template <class T>
std::optional<T> read(std::span<const std::byte> body, std::size_t& off, std::endian order) {
  off = (off + sizeof(T) - 1) / sizeof(T) * sizeof(T);
  if (off + sizeof(T) > body.size()) return std::nullopt;
  T v;
  std::memcpy(&v, body.data() + off, sizeof(T));
  if (order != std::endian::native) {
    auto* b = reinterpret_cast<unsigned char*>(&v);
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
  }
  off += sizeof(T);
  return v;
}

inline std::optional<std::string_view> read_string(std::span<const std::byte> body, std::size_t& off, std::endian order) {
  const auto len = read<std::uint32_t>(body, off, order);
  if (!len || *len == 0 || off + *len > body.size()) return std::nullopt;
  std::string_view s(reinterpret_cast<const char*>(body.data() + off), *len - 1);
  off += *len;
  return s;
}

// The encapsulation header's byte order (CDR_BE 0x0000, CDR_LE 0x0001); nullopt for anything else.
inline std::optional<std::endian> order_of(std::span<const std::byte> header) {
  if (header.size() < 4 || header[0] != std::byte{0}) return std::nullopt;
  if (header[1] == std::byte{1}) return std::endian::little;
  if (header[1] == std::byte{0}) return std::endian::big;
  return std::nullopt;
}

// std_msgs/Header's stamp, the first member of a stamped message, in ns.
inline std::optional<Nanos> header_stamp(std::span<const std::byte> body, std::endian order) {
  std::size_t off = 0;
  const auto sec = read<std::int32_t>(body, off, order);
  const auto nsec = read<std::uint32_t>(body, off, order);
  if (!sec || !nsec) return std::nullopt;
  return static_cast<Nanos>(*sec) * 1'000'000'000 + static_cast<Nanos>(*nsec);
}

struct Announced {
  Nanos stamp = 0;
  std::string_view topic;
  Nanos publish_ns = 0;
};

// sensor_rig_msgs/SourceStamps: header, topic, seq, then acquisition .. publish_ns (int64 each).
inline std::optional<Announced> source_stamps(std::span<const std::byte> body, std::endian order) {
  Announced a;
  const auto stamp = header_stamp(body, order);
  std::size_t off = 8;
  if (!stamp || !read_string(body, off, order)) return std::nullopt;  // frame_id
  const auto topic = read_string(body, off, order);
  if (!topic || !read<std::uint64_t>(body, off, order)) return std::nullopt;  // seq
  for (int i = 0; i < 4; ++i)
    if (!read<std::int64_t>(body, off, order)) return std::nullopt;  // acquisition, first_rx, last_rx, ready
  const auto publish = read<std::int64_t>(body, off, order);
  if (!publish) return std::nullopt;
  a.stamp = *stamp;
  a.topic = *topic;
  a.publish_ns = *publish;
  return a;
}

}  // namespace record_cdr

class AnnouncedSamples {
 public:
  // A sample of `topic` with header stamp `stamp` taken at `now` (monotonic ns).
  void on_data(const std::string& topic, Nanos stamp, Nanos now) {
    Topic& t = topics_[topic];
    if (t.announced.erase(stamp) == 0) t.received.insert_or_assign(stamp, now);
  }
  // /rig/stamps announced a sample of `topic` at `stamp`, received here at `now`.
  void on_announced(const std::string& topic, Nanos stamp, Nanos now) {
    Topic& t = topics_[topic];
    if (t.received.erase(stamp) == 0) t.announced.insert_or_assign(stamp, now);
  }
  // Announcements older than `timeout_ns` without their sample: `missed(topic)` once each, then
  // forgotten; received samples no announcement came for within 5 timeouts are forgotten too.
  template <class F>
  void expire(Nanos now, Nanos timeout_ns, F&& missed) {
    for (auto& [name, t] : topics_) {
      std::erase_if(t.announced, [&](const auto& kv) {
        if (now - kv.second <= timeout_ns) return false;
        missed(name);
        return true;
      });
      std::erase_if(t.received, [&](const auto& kv) { return now - kv.second > 5 * timeout_ns; });
    }
  }

 private:
  struct Topic {
    std::map<Nanos, Nanos> announced, received;  // header stamp -> when (monotonic)
  };
  std::map<std::string, Topic, std::less<>> topics_;
};

}  // namespace sensor_rig::rig
