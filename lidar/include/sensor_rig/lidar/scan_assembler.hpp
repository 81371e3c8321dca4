#pragma once
// Scan bookkeeping shared by the vendor decoders (velodyne, ouster, hesai): the scan being
// assembled, packet and scan counters, sequence numbers, the reserve guess and the recycling of
// published buffers, so that the hot path allocates nothing once the first scans have been seen.
// Where a scan ends (cut angle, frame id, time jump) stays the vendor's decision; this only does
// what follows from it. Pure: no I/O, no clock reads; nothing here throws but a failed reserve.
//
//   ScanAssembler scans({.first_reserve = n, .emit_partial_scans = p}, stats);
//   if (!scans.accept(check_packet(...))) return std::nullopt;   // counted, a drop in the scan
//   scans.begin_packet();
//   scans.current().touch(stamp, rx);  scans.scan().points.push_back(...);
//   if (cut) out = scans.end_scan(scans.current().from_cut, true);
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "sensor_rig/lidar/packet.hpp"
#include "sensor_rig/lidar/packet_time.hpp"  // is_time_jump, TimeJudge (were here)
#include "sensor_rig/lidar/point_cloud.hpp"

namespace sensor_rig::lidar {

// The counters every vendor decoder keeps; a vendor's DecoderStats derives and may count more.
struct ScanStats {
  std::uint64_t packets = 0;                                  // pushed
  std::uint64_t packets_used = 0;                             // decoded into points
  std::array<std::uint64_t, kPacketStatusCount> by_status{};  // indexed by PacketStatus
  std::uint64_t scans = 0;                                    // emitted
  std::uint64_t partial_scans_discarded = 0;
  std::uint64_t time_jumps = 0;  // scans ended early because the packet time jumped
  // The caller's stamps jumped while the sensor's own time went on (its mapping moved: a host clock
  // step): no time jump (packet_time.hpp). Hesai, Ouster; Velodyne's stamps are its time.
  std::uint64_t mapping_steps = 0;
  std::uint64_t missing_packets = 0;      // lost between received packets (inside the FOV), summed over scans
  std::uint64_t implausible_steps = 0;    // corrupted azimuths / frame or measurement ids: dropped, not cuts
  std::uint64_t late_placed = 0;   // late (reordered) packets put into the hole they left in their scan
  // Scans the decoder knows it lost (issue 26): partial scans discarded, and whole turns the sensor
  // time says passed while every packet was lost or rejected (stuck azimuth, loss bursts).
  std::uint64_t scans_lost = 0;
  // Silences (stream_gap.hpp): nothing heard for turns and the sensor's time or numbering moved on
  // or began again; a new stream followed, its turns not counted lost (the sensor made none).
  std::uint64_t silences = 0;
  // Whole turns inside silences of a model without numbering (stream_gap.hpp scans_unheard): lost
  // on the way or never made, the decoder cannot tell which. Neither published nor in scans_lost.
  std::uint64_t scans_unheard = 0;
  [[nodiscard]] std::uint64_t dropped() const noexcept { return packets - packets_used; }
};

// Where the current scan lost packets (the last gap counted missing): a late packet that lands
// there is placed, and the missing count goes down (issue 26 item 1). Positions are the vendor's:
// azimuth (0.01°) or packet slots.
struct LateHole {
  long from = 0, to = 0;    // exclusive ends, forward from `from` (wrapping at `wrap` when > 0)
  long wrap = 0;
  std::uint32_t open = 0;   // missing packets not yet arrived
  [[nodiscard]] bool holds(long at) const noexcept {
    if (open == 0) return false;
    long d = at - from, span = to - from;
    if (wrap > 0) {
      d = ((d % wrap) + wrap) % wrap;
      span = ((span % wrap) + wrap) % wrap;
    }
    return d > 0 && d < span;
  }
};

// A scan being assembled, with what the decoder knows about it.
struct PendingScan {
  Scan scan;
  bool started = false;   // has its stamp: a firing was decoded into it
  bool counted = false;   // the packet being decoded is already counted in scan.packets
  bool from_cut = false;  // began at a cut (frame start): complete once the next cut ends it

  // The packet being decoded puts data into this scan: the first firing stamps the scan, each
  // packet counts once, and the scan's last receive time follows the packet.
  void touch(Nanos stamp, Nanos rx_ns) noexcept {
    if (!started) {
      scan.stamp = stamp;
      scan.first_rx_ns = rx_ns;
      started = true;
    }
    if (!counted) {
      ++scan.packets;
      counted = true;
    }
    scan.last_rx_ns = rx_ns;
  }
  // A late packet fired before the scan's stamp: the scan starts at it, the points' t move on.
  void rebase(Nanos earlier) noexcept {
    if (!started || earlier >= scan.stamp) return;
    const auto shift = static_cast<std::uint32_t>(std::min<Nanos>(scan.stamp - earlier, 0xFFFF'FFFFLL));
    for (auto& p : scan.points) p.t += shift;
    scan.stamp = earlier;
  }
  // Has packets and a stamp: worth emitting.
  [[nodiscard]] bool has_data() const noexcept { return scan.packets > 0 && started; }
};

struct ScanAssemblerOptions {
  std::size_t first_reserve = 0;  // points reserved before any scan has been emitted
  // Later scans reserve the last emitted scan's size + 1/8, at most this.
  std::size_t max_reserve = std::numeric_limits<std::size_t>::max();
  std::size_t spare_buffers = 2;  // recycled buffers kept for reuse
  bool emit_partial_scans = false;
  // Keep a second scan (next()) that receives the points already past the cut while the current
  // one is still being completed (Hesai's per-point cut); end_scan() promotes it.
  bool lookahead = false;
};

class ScanAssembler {
 public:
  // `stats` (the decoder's, which outlives this) receives the packet and scan counts.
  ScanAssembler(const ScanAssemblerOptions& options, ScanStats& stats);
  ScanAssembler(const ScanAssembler&) = delete;
  ScanAssembler& operator=(const ScanAssembler&) = delete;
  ScanAssembler(ScanAssembler&&) = delete;
  ScanAssembler& operator=(ScanAssembler&&) = delete;
  ~ScanAssembler() = default;

  [[nodiscard]] PendingScan& current() noexcept { return cur_; }
  [[nodiscard]] const PendingScan& current() const noexcept { return cur_; }
  [[nodiscard]] Scan& scan() noexcept { return cur_.scan; }
  // The lookahead scan (only with ScanAssemblerOptions::lookahead).
  [[nodiscard]] PendingScan& next() noexcept { return nxt_; }

  // Counts a pushed packet under its status. Not kOk: also a drop in the current scan; false.
  bool accept(PacketStatus status) noexcept {
    ++stats_.packets;
    if (status != PacketStatus::kOk) {
      ++stats_.by_status[static_cast<std::size_t>(status)];
      ++cur_.scan.dropped;
      if (takes_slot(status)) ++rejected_;
      return false;
    }
    ++stats_.packets_used;
    ++stats_.by_status[0];
    return true;
  }
  // An accepted packet the decoder then rejects (steps back, no plausible azimuth): counted as
  // `status` instead, a drop in the current scan.
  void reject(PacketStatus status) noexcept {
    --stats_.packets_used;
    --stats_.by_status[0];
    ++stats_.by_status[static_cast<std::size_t>(status)];
    ++cur_.scan.dropped;
    if (takes_slot(status)) ++rejected_;
  }
  // A packet rejected while decoding, the same counters for every vendor: `why` in the status
  // counts and the scan's `dropped`; a corrupt one (azimuth, ids, time) also an implausible step.
  // Returns `why` (the decoder's last status).
  PacketStatus drop(PacketStatus why) noexcept {
    if (why == PacketStatus::kBadAzimuth || why == PacketStatus::kBadTime) ++stats_.implausible_steps;
    reject(why);
    return why;
  }
  // One rule for every vendor (issue 26 item 7): a packet rejected whole (bad length, flag,
  // azimuths, ids, time) was sent in its place of the stream; it is counted `dropped`, so the gap
  // the next decoded packet shows is first its: missing only beyond the rejected ones. A duplicate
  // or late packet (kOutOfOrder) and a non-data packet (kNotData) hold no place of their own.
  [[nodiscard]] static constexpr bool takes_slot(PacketStatus s) noexcept {
    return s != PacketStatus::kOutOfOrder && s != PacketStatus::kNotData;
  }
  // Packets rejected whole since the last one decoded (or since clear_rejected()).
  [[nodiscard]] std::uint32_t rejected_since_kept() const noexcept { return rejected_; }
  // Of `slots` packets a gap lacks, those not taken by rejected packets (which it uses up): missing.
  [[nodiscard]] std::uint32_t missing_beyond_rejected(std::uint32_t slots) noexcept {
    const std::uint32_t r = std::min(slots, rejected_);
    rejected_ -= r;
    return slots - r;
  }
  // A packet was decoded (its gap judged), or continuity starts over: no rejected packet pending.
  void clear_rejected() noexcept { rejected_ = 0; }
  // `n` packets were lost inside the current scan.
  void add_missing(std::uint32_t n) noexcept {
    cur_.scan.missing_packets += n;
    stats_.missing_packets += n;
  }
  // `n` packets lost with data in the lookahead scan as well (Hesai: inside the cut's window).
  void add_missing_next(std::uint32_t n) noexcept {
    nxt_.scan.missing_packets += n;
    stats_.missing_packets += n;
  }
  // A packet counted missing in the lookahead scan arrived late after all.
  void fill_missing_next() noexcept {
    if (nxt_.scan.missing_packets == 0) return;
    --nxt_.scan.missing_packets;
    --stats_.missing_packets;
  }
  // A packet counted missing in the current scan arrived late after all.
  void fill_missing() noexcept {
    if (cur_.scan.missing_packets == 0) return;
    --cur_.scan.missing_packets;
    --stats_.missing_packets;
    ++stats_.late_placed;
  }
  // Scans lost as a whole (no sample for them).
  void lose_scans(std::uint64_t n) noexcept { stats_.scans_lost += n; }
  // A new packet is being decoded: no scan has counted it yet.
  void begin_packet() noexcept {
    cur_.counted = false;
    nxt_.counted = false;
  }

  // Ends the current scan. Returns it (with the next sequence number) when it has data and is
  // `complete` or partial scans are emitted; otherwise it is counted as discarded (if it had
  // packets), its buffer is reused and its drops carry over into the next scan. The lookahead
  // scan (or a fresh one) becomes current; `next_from_cut` marks it as starting at a cut.
  std::optional<Scan> end_scan(bool complete, bool next_from_cut = false) noexcept;
  // Discards the lookahead scan (counted as discarded if it had packets).
  void drop_next() noexcept;
  // Discards the lookahead scan uncounted: its turn is one the caller counts lost whole (a loss
  // burst from inside the cut's window over the next turn).
  void forget_next() noexcept {
    recycle(std::move(nxt_.scan.points));
    nxt_ = fresh();
  }
  // `later` ended in the same packet as `out` (a time jump, then a cut): keeps `later`; the
  // earlier one is un-counted as emitted and counted as discarded.
  void merge(std::optional<Scan>& out, std::optional<Scan>&& later) noexcept;
  // Returns the current scan if it has data (partial or not) and resets both scans. A lookahead
  // scan and a current scan without data are discarded without being counted.
  std::optional<Scan> flush() noexcept;
  // A published scan's buffer back for reuse; kept if fewer than spare_buffers are held.
  void recycle(std::vector<PointXYZIRT>&& buffer) noexcept;

  [[nodiscard]] std::size_t spare_count() const noexcept { return spare_.size(); }

 private:
  PendingScan fresh() noexcept;
  std::optional<Scan> emit() noexcept;

  ScanAssemblerOptions options_;
  ScanStats& stats_;
  PendingScan cur_;
  PendingScan nxt_;
  std::size_t last_scan_points_ = 0;
  std::uint64_t next_seq_ = 0;
  std::uint32_t rejected_ = 0;  // rejected_since_kept()
  std::vector<std::vector<PointXYZIRT>> spare_;
};

// Defined here, in every vendor decoder's translation unit: end_scan() and the rest run inside the
// packet loops, and a call the compiler cannot see into (another translation unit) costs the hot
// loop its registers; inlined into the loop they cost it its layout. So: visible, not inlined
// (Pandar40P dual, ns/packet: out of line in scan_assembler.cpp +8 %, inlined +5 %, this +0).

// An empty scan, in a recycled buffer when there is one, reserved for the expected size.
inline PendingScan ScanAssembler::fresh() noexcept {
  const std::size_t guess = last_scan_points_ != 0
                                ? std::min(options_.max_reserve, last_scan_points_ + last_scan_points_ / 8)
                                : options_.first_reserve;
  PendingScan p;
  if (!spare_.empty()) {
    p.scan.points = std::move(spare_.back());
    spare_.pop_back();
    p.scan.points.clear();
  }
  p.scan.points.reserve(guess);
  return p;
}

inline std::optional<Scan> ScanAssembler::emit() noexcept {
  last_scan_points_ = cur_.scan.points.size();
  cur_.scan.seq = next_seq_++;
  ++stats_.scans;
  return std::move(cur_.scan);
}

inline std::optional<Scan> ScanAssembler::end_scan(bool complete, bool next_from_cut) noexcept {
  std::optional<Scan> out;
  std::uint32_t carried_drops = 0;
  if (cur_.has_data() && (complete || options_.emit_partial_scans)) {
    out = emit();
  } else {
    if (cur_.scan.packets > 0) {
      ++stats_.partial_scans_discarded;
      ++stats_.scans_lost;
    }
    carried_drops = cur_.scan.dropped;  // drops stay visible in the next emitted scan
    recycle(std::move(cur_.scan.points));
  }
  if (options_.lookahead) {
    cur_ = std::move(nxt_);
    nxt_ = fresh();
  } else {
    cur_ = fresh();
  }
  cur_.scan.dropped += carried_drops;
  cur_.from_cut = cur_.from_cut || next_from_cut;
  return out;
}

inline void ScanAssembler::drop_next() noexcept {
  if (nxt_.scan.packets > 0) {
    ++stats_.partial_scans_discarded;
    ++stats_.scans_lost;
  }
  recycle(std::move(nxt_.scan.points));
  nxt_ = fresh();
}

inline void ScanAssembler::merge(std::optional<Scan>& out, std::optional<Scan>&& later) noexcept {
  if (!later) return;
  if (out) {
    --stats_.scans;
    ++stats_.partial_scans_discarded;
    ++stats_.scans_lost;
    later->seq = out->seq;  // published sequence numbers stay gapless: a gap is a loss downstream
    --next_seq_;
    recycle(std::move(out->points));
  }
  out = std::move(later);
}

inline void ScanAssembler::recycle(std::vector<PointXYZIRT>&& buffer) noexcept {
  if (spare_.size() < options_.spare_buffers && buffer.capacity() > 0) spare_.push_back(std::move(buffer));
}

}  // namespace sensor_rig::lidar
