#pragma once
// `rig record`: samples the rig announced on /rig/stamps that never reached the recorder. DDS does
// not say (Cyclone 0.10 reports no SAMPLE_LOST when a reliable keep-last writer drops samples a
// slow reader had not acknowledged: a recorder stopped 2.5 s missed 8-25 samples per topic and
// counted 0, tests/record/record_monitor_counts_test.cpp). The drivers announce every sample they
// write (topic, header stamp, seq), as `rig monitor` uses them: a sample announced and not received
// within the timeout is counted missed on its topic, and so is a sample whose announcement was lost
// too (a gap in seq; AnnouncedSamples). Pure bookkeeping: no DDS, no I/O.
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <deque>
#include <iterator>
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
  std::uint64_t seq = 0;
  Nanos publish_ns = 0;
  std::uint64_t published = 0;  // the writer's count of this topic's announcements (0: not counted)
};

// sensor_rig_msgs/SourceStamps: header, topic, seq, acquisition .. written_ns (int64 each), four
// uint32, ecu_status_ns, published (uint64; absent from a writer before it: 0).
inline std::optional<Announced> source_stamps(std::span<const std::byte> body, std::endian order) {
  Announced a;
  const auto stamp = header_stamp(body, order);
  std::size_t off = 8;
  if (!stamp || !read_string(body, off, order)) return std::nullopt;  // frame_id
  const auto topic = read_string(body, off, order);
  if (!topic) return std::nullopt;
  const auto seq = read<std::uint64_t>(body, off, order);
  if (!seq) return std::nullopt;
  for (int i = 0; i < 4; ++i)
    if (!read<std::int64_t>(body, off, order)) return std::nullopt;  // acquisition, first_rx, last_rx, ready
  const auto publish = read<std::int64_t>(body, off, order);
  if (!publish) return std::nullopt;
  a.stamp = *stamp;
  a.topic = *topic;
  a.seq = *seq;
  a.publish_ns = *publish;
  const bool tail = read<std::int64_t>(body, off, order) && read<std::uint32_t>(body, off, order) &&
                    read<std::uint32_t>(body, off, order) && read<std::uint32_t>(body, off, order) &&
                    read<std::uint32_t>(body, off, order) && read<std::int64_t>(body, off, order);
  if (tail)
    if (const auto published = read<std::uint64_t>(body, off, order)) a.published = *published;
  return a;
}

}  // namespace record_cdr

// What the recorder missed, per topic, exactly, with bounded memory.
//  - An announcement without its sample once a later sample of the topic came (or, none coming,
//    after the timeout): missed (the join, by header stamp).
//  - Announcements lost too: a recorder stopped for seconds gets only the last 64 of the rig's
//    /rig/stamps writer (keep-last 64, one history for every topic; dds/stamps_writer.cpp) and what
//    its socket held; the rest never come, and neither do their samples. They show as a gap in the
//    topic's SourceStamps.seq between two announcements that did come: every sample of the gap is
//    missed except those received (data whose stamp lies inside the gap and matched nothing),
//    decided once a later sample came or a timeout after the gap was seen. The gap is read from
//    SourceStamps.published, the writer's own gapless count of the topic's announcements, where
//    the writer numbers them (every driver since it was added): exact on every topic, cameras too.
//    Else from seq: on topics whose seq is a device's frame id (cameras: a gap is also a frame the
//    camera made and the rig never published) the count is `unannounced` instead, an upper bound
//    beside `missed`, never folded into it. On the dbw bridge's commands (stamped when transmitted)
//    a gap is nothing. A count that goes back (a driver's process restarted; for seq also a camera
//    reopened) starts over without a gap, but for a GigE camera's 16-bit frame id wrapping; a gap at
//    the very end (no later announcement) is not seen.
// Bounds, per topic: kMaxPending announcements waiting for their sample, kMaxPending samples waiting
// for their announcement, kMaxGaps undecided gaps (std::map / std::deque nodes: ~0.6 MB per topic at
// most, ~25 MB for a 40-topic recording). Past them nothing is silent: the oldest waiting
// announcement is counted missed at once, the oldest waiting sample is forgotten (its announcement,
// if it comes, is then counted missed), the two oldest gaps merge (exact: stamps are monotonic per
// topic, so what lies between two gaps is matched and never waiting); each forced decision is
// counted in `overflow`.
class AnnouncedSamples {
 public:
  static constexpr std::size_t kMaxPending = 4096;
  static constexpr std::size_t kMaxGaps = 256;

  struct Counts {
    std::uint64_t missed = 0;       // announced (or in a kMissed seq gap), never received
    std::uint64_t unannounced = 0;  // in a kUnannounced seq gap, never received
    std::uint64_t overflow = 0;     // decisions the bounds forced (see above)
  };

  // What a gap in a topic's seq is. kMissed: its seq counts the published samples (LIDAR scans, the
  // fused cloud, vehicle state). kUnannounced: a device's frame id (cameras). kNotCounted: a seq that
  // skips by design (the dbw bridge stamps the commands it transmits, not every one it takes).
  enum class SeqGaps { kMissed, kUnannounced, kNotCounted };
  void set_seq_gaps(const std::string& topic, SeqGaps gaps) { topics_[topic].seq_gaps = gaps; }

  // A sample of `topic` with header stamp `stamp` taken at `now` (monotonic ns).
  void on_data(const std::string& topic, Nanos stamp, Nanos now) {
    Topic& t = topics_[topic];
    if (!t.has_data || stamp > t.newest_data) t.newest_data = stamp;
    t.has_data = true;
    if (t.announced.erase(stamp) != 0) return;
    t.received.insert_or_assign(stamp, now);
    if (t.received.size() > kMaxPending) {
      t.received.erase(t.received.begin());
      if (t.has_seq) ++t.counts.overflow;  // a topic never announced (camera_info, raw packets) loses nothing by it
    }
  }

  // /rig/stamps announced sample `seq` of `topic` at `stamp`, received here at `now`; `published`
  // its writer's count of the topic's announcements (0: not counted). `counted` false: before the
  // recorder's reader of the topic matched (only the counts are kept, to see gaps).
  void on_announced(const std::string& topic, Nanos stamp, std::uint64_t seq, Nanos now, bool counted = true,
                    std::uint64_t published = 0) {
    Topic& t = topics_[topic];
    if (t.has_seq && seq == t.last_seq && stamp == t.last_stamp) return;  // the same announcement again
    if (t.has_seq && counted && t.seq_gaps != SeqGaps::kNotCounted) {
      if (published > 0 && t.last_published > 0) {
        if (published > t.last_published + 1) add_gap(t, Gap{t.last_stamp, stamp, published - t.last_published - 1, now, true});
      } else if (published == 0) {
        std::uint64_t between = seq > t.last_seq + 1 ? seq - t.last_seq - 1 : 0;
        // A GigE camera's 16-bit frame id wrapped (65535 is followed by 1): not a restart.
        if (t.seq_gaps == SeqGaps::kUnannounced && seq < t.last_seq && t.last_seq <= 0xFFFF && t.last_seq - seq > 0x8000)
          between = (0xFFFF - t.last_seq) + (seq > 0 ? seq - 1 : 0);
        if (between > 0) add_gap(t, Gap{t.last_stamp, stamp, between, now, t.seq_gaps == SeqGaps::kMissed});
      }
    }
    t.has_seq = true;
    t.last_seq = seq;
    t.last_published = published;
    t.last_stamp = stamp;
    if (!counted) return;
    if (t.received.erase(stamp) != 0) return;
    t.announced.insert_or_assign(stamp, now);
    if (t.announced.size() > kMaxPending) {
      t.announced.erase(t.announced.begin());
      ++t.counts.missed;
      ++t.counts.overflow;
    }
  }

  // Decides what can no longer come: a topic's samples arrive in the order they were written (one
  // reliable writer: DDS drops, never reorders), so once a later sample of the topic came, an
  // announcement without its sample is missed and a gap counts its samples not received. Without
  // a later sample, after `timeout_ns` (a topic that went quiet; a recorder catching up receives
  // the repair of a large sample seconds after the announcements around it). Received samples no
  // announcement came for within 5 timeouts are forgotten. `gap_timeout_ns` (default: the same)
  // for gaps: at the stop, once every sample was taken, 0 decides them all (what they lack is not
  // in the file).
  void expire(Nanos now, Nanos timeout_ns, std::optional<Nanos> gap_timeout_ns = std::nullopt) {
    const Nanos gap_timeout = gap_timeout_ns.value_or(timeout_ns);
    for (auto& [name, t] : topics_) {
      while (!t.gaps.empty()) {
        const Gap& g = t.gaps.front();
        if (gap_timeout != 0 && now - g.seen <= gap_timeout && !(t.has_data && t.newest_data >= g.before)) break;
        decide(t, g);
        t.gaps.pop_front();
      }
      std::erase_if(t.announced, [&](const auto& kv) {
        if (now - kv.second <= timeout_ns && !(t.has_data && t.newest_data > kv.first)) return false;
        ++t.counts.missed;
        return true;
      });
      std::erase_if(t.received, [&](const auto& kv) { return now - kv.second > 5 * timeout_ns; });
    }
  }

  [[nodiscard]] Counts counts(const std::string& topic) const {
    const auto it = topics_.find(topic);
    return it == topics_.end() ? Counts{} : it->second.counts;
  }

  // Entries held (announced + received + gaps) over every topic: what the bounds bound.
  [[nodiscard]] std::size_t held() const {
    std::size_t n = 0;
    for (const auto& [name, t] : topics_) n += t.announced.size() + t.received.size() + t.gaps.size();
    return n;
  }

 private:
  struct Gap {
    Nanos after = 0, before = 0;  // the header stamps of the announcements around it (exclusive)
    std::uint64_t samples = 0;    // announcements between them
    Nanos seen = 0;
    bool published = true;        // counted samples the rig published (else maybe frames it never had)
  };
  struct Topic {
    std::map<Nanos, Nanos> announced, received;  // header stamp -> when (monotonic)
    std::deque<Gap> gaps;                        // in seq order
    SeqGaps seq_gaps = SeqGaps::kMissed;
    bool has_seq = false, has_data = false;
    std::uint64_t last_seq = 0;
    std::uint64_t last_published = 0;
    Nanos last_stamp = 0;
    Nanos newest_data = 0;  // the newest sample's header stamp
    Counts counts;
  };

  static void add_gap(Topic& t, Gap g) {
    t.gaps.push_back(g);
    if (t.gaps.size() <= kMaxGaps) return;
    // Merged: the samples between the two were announced, so none of them waits in `received`.
    Gap& second = t.gaps[1];
    if (second.published != t.gaps.front().published) {  // a rig restarted in between: decided apart
      decide(t, t.gaps.front());
      t.gaps.pop_front();
      ++t.counts.overflow;
      return;
    }
    second.after = t.gaps.front().after;
    second.samples += t.gaps.front().samples;
    t.gaps.pop_front();
    ++t.counts.overflow;
  }

  static void decide(Topic& t, const Gap& g) {
    std::uint64_t received = 0;
    if (g.after < g.before) {
      const auto from = t.received.upper_bound(g.after);
      const auto to = t.received.lower_bound(g.before);
      received = static_cast<std::uint64_t>(std::distance(from, to));
      t.received.erase(from, to);
    }
    const std::uint64_t lost = g.samples > received ? g.samples - received : 0;
    (g.published ? t.counts.missed : t.counts.unannounced) += lost;
  }

  std::map<std::string, Topic, std::less<>> topics_;
};

}  // namespace sensor_rig::rig
