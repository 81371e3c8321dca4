// Hesai decoder: scan assembly with nebula's per-point scan cut, echo selection, the hot loop.
#include "sensor_rig/lidar/hesai/decoder.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <string>

#include "sensor_rig/lidar/detail/azimuth_continuity.hpp"
#include "sensor_rig/lidar/detail/decoder_pimpl_impl.hpp"
#include "sensor_rig/lidar/packet_order.hpp"
#include "sensor_rig/lidar/packet_time.hpp"
#include "sensor_rig/lidar/stream_gap.hpp"
#include "sensor_rig/lidar/hesai/packet.hpp"

#include "azimuth_math.hpp"

namespace sensor_rig::lidar::hesai {
namespace {

constexpr std::int64_t kMicroDeg = 360'000'000;      // a turn in µ°
constexpr std::int64_t kNextScanSpan = 20'000'000;   // nebula: points up to 20° past the cut go to the next scan

struct ChannelTable {
  float cos_el, sin_el;
  float cos_off, sin_off;      // azimuth offset
  std::int64_t off_udeg;       // azimuth offset in µ° (exact scan-cut test)
  std::uint32_t fire_rel_ns;   // firing time after the group's first firing
  std::uint16_t ring;
};

struct Echo {
  std::uint16_t raw;
  std::uint8_t refl;
};

// A lookahead scan holds the points already past the cut; three spare buffers cover the two scans
// being assembled plus the one the caller is publishing.
ScanAssemblerOptions scan_options(const DecoderConfig& cfg) {
  const std::size_t dual = cfg.returns == ReturnSelection::kDual ? 2 : 1;
  const std::size_t typical = static_cast<std::size_t>(model_info(cfg.model).typical_points_per_scan) * dual;
  return {.first_reserve = cfg.first_scan_reserve_points != 0 ? cfg.first_scan_reserve_points : typical,
          .spare_buffers = 3,
          .emit_partial_scans = cfg.emit_partial_scans,
          .lookahead = true};
}

}  // namespace

struct DecoderImpl {
  DecoderConfig cfg;
  const ModelInfo* mi;
  std::vector<ChannelTable> ch;
  std::vector<std::uint16_t> ring_of_channel;
  Nanos min_fire_ns = 0;
  float min_range = 0.0F;
  float max_range = 0.0F;
  std::int64_t cut_udeg = 0;
  int reset_raw = 0;  // raw azimuth window [reset_raw, emit_raw] where channels straddle the cut
  int emit_raw = 0;

  DecoderStats stats;
  PacketStatus last = PacketStatus::kOk;
  int last_returns = 1;
  ScanAssembler scans;  // current(): the scan being assembled; next(): points already past the cut
  bool have_prev = false;
  bool window_open = false;  // between the window's start and the cut: points past the cut go to next()
  int prev_az = 0;
  Nanos prev_stamp = 0;  // the caller's
  ArrivalLateness lateness;  // how late the last kept packet came (a held network's queue drains at once)
  RxTimes prev_rx;  // the previous packet's receive time (0: none)
  // The caller's mapping of sensor time may move while the sensor's clock goes on (a host
  // CLOCK_REALTIME step: the mapping follows the host, a PTP-synced sensor does not): the stamps
  // jump, the tail times do not. That is no time jump (it cost the scan across it and a dropped
  // packet); the scans already begun stay on their line (stamps less line_shift) and the scan after
  // the next cut moves onto the caller's. A time jump is both clocks jumping.
  Nanos line_shift = 0;
  Nanos prev_own = 0;  // the previous packet's stamp on its line
  detail::AzimuthFov fov;
  int prev_trailing_bad = 0;
  std::int64_t prev_sensor_us = 0;  // the previous packet's tail time of day (µs)
  bool have_seq = false;
  std::uint32_t prev_seq = 0;       // UDP sequence number (expected value after a mismatch)
  LateHole hole;                    // where the current scan last counted packets missing
  // The hole is the scan's after a cut, begun inside the cut's window: a late packet there has only
  // its channels past the cut in it (those before are the published scan's, which lacks them).
  bool hole_after_cut = false;
  // Packets lost inside the cut's window, counted missing in the lookahead scan too: where they lie,
  // so that once the cut is done (the lookahead scan current) a late one is placed there.
  LateHole window_hole;
  TimeJudge time_judge;
  bool turning = false;  // the last good packet's azimuth advanced: a frozen one is a fault
  detail::BlindArc blind;  // a sector the sensor stopped sending (learned, not loss)
  StreamGap gaps;           // when the sensor was last heard (a silence is no loss)
  double turning_step = 0;  // azimuth per group of the last turning packet (0.01°): the turn's length

  explicit DecoderImpl(DecoderConfig config)
      : cfg(std::move(config)), mi(&model_info(cfg.model)), scans(scan_options(cfg), stats) {
    if (!(cfg.min_range_m >= 0.0) || !(cfg.max_range_m > cfg.min_range_m)) {
      throw DecoderConfigError("range: need 0 <= min_range (" + std::to_string(cfg.min_range_m) +
                               ") < max_range (" + std::to_string(cfg.max_range_m) + ")");
    }
    if (!(cfg.cut_angle_deg >= 0.0 && cfg.cut_angle_deg < 360.0))
      throw DecoderConfigError("cut angle " + std::to_string(cfg.cut_angle_deg) + " is not in [0, 360)");
    if (cfg.max_packet_gap_ns <= 0) throw DecoderConfigError("max_packet_gap_ns must be positive");
    if (!(cfg.dual_distance_threshold_m >= 0.0)) throw DecoderConfigError("dual_distance_threshold_m must be >= 0");
    if (!(cfg.fov_start_deg >= 0.0 && cfg.fov_start_deg <= 360.0 && cfg.fov_end_deg >= 0.0 && cfg.fov_end_deg <= 360.0))
      throw DecoderConfigError("fov: start and end must be in [0, 360] degrees");
    fov = detail::make_fov(cfg.fov_start_deg, cfg.fov_end_deg);
    if (!cfg.calibration) cfg.calibration = default_calibration(cfg.model);
    if (!cfg.firing_times) cfg.firing_times = default_firing_times(cfg.model);
    const auto n = static_cast<std::size_t>(mi->channels);
    if (cfg.calibration->channels.size() != n || cfg.firing_times->us.size() != n) {
      throw DecoderConfigError(cfg.calibration->source + ": " + std::to_string(cfg.calibration->channels.size()) +
                               " channels, " + std::string(mi->name) + " has " + std::to_string(n));
    }
    min_range = static_cast<float>(cfg.min_range_m);
    max_range = std::isinf(cfg.max_range_m) ? std::numeric_limits<float>::max() : static_cast<float>(cfg.max_range_m);
    cut_udeg = std::llround(cfg.cut_angle_deg * 1e6) % kMicroDeg;

    const auto& cal = cfg.calibration->channels;
    const auto& fire = cfg.firing_times->us;
    min_fire_ns = std::llround(*std::min_element(fire.begin(), fire.end()) * 1000.0);
    std::vector<std::size_t> order(n);
    for (std::size_t i = 0; i < n; ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return cal[a].elevation_deg < cal[b].elevation_deg; });
    ring_of_channel.resize(n);
    for (std::size_t r = 0; r < n; ++r) ring_of_channel[order[r]] = static_cast<std::uint16_t>(r);
    long off_min = 0, off_max = 0;
    ch.resize(n);
    for (std::size_t c = 0; c < n; ++c) {
      const double el = cal[c].elevation_deg * std::numbers::pi / 180.0;
      const double off = cal[c].azimuth_deg * std::numbers::pi / 180.0;
      auto& t = ch[c];
      t.cos_el = static_cast<float>(std::cos(el));
      t.sin_el = static_cast<float>(std::sin(el));
      t.cos_off = static_cast<float>(std::cos(off));
      t.sin_off = static_cast<float>(std::sin(off));
      t.off_udeg = std::llround(cal[c].azimuth_deg * 1e6);
      t.fire_rel_ns = static_cast<std::uint32_t>(std::llround(fire[c] * 1000.0) - min_fire_ns);
      t.ring = ring_of_channel[c];
      const long o = round_away(cal[c].azimuth_deg * 100.0);
      off_min = c == 0 ? o : std::min(off_min, o);
      off_max = c == 0 ? o : std::max(off_max, o);
    }
    // nebula's window: from the first raw azimuth where some channel reaches the cut to the one
    // where every channel has passed it.
    reset_raw = norm_az(static_cast<long>(std::floor(cfg.cut_angle_deg * 100.0)) - off_max);
    emit_raw = norm_az(static_cast<long>(std::ceil(cfg.cut_angle_deg * 100.0)) - off_min);
    last_returns = cfg.returns == ReturnSelection::kDual ? 2 : 1;
  }

  inline void point(Scan& s, const ChannelTable& t, Echo e, float unit, float sa, float ca, Nanos group_stamp,
                    std::uint8_t rtype) {
    const float d = static_cast<float>(e.raw) * unit;
    if (e.raw == 0 || d < min_range || d > max_range) return;
    const float sin_a = sa * t.cos_off + ca * t.sin_off;
    const float cos_a = ca * t.cos_off - sa * t.sin_off;
    const float xy = d * t.cos_el;
    Nanos rel = group_stamp - s.stamp + t.fire_rel_ns;
    rel = std::clamp<Nanos>(rel, 0, std::numeric_limits<std::uint32_t>::max());
    s.points.push_back(PointXYZIRT{xy * cos_a, -xy * sin_a, d * t.sin_el, static_cast<float>(e.refl),
                                   static_cast<std::uint32_t>(rel), t.ring, rtype, 0});
  }

  PacketStatus check(std::span<const std::byte> bytes) const noexcept { return check_packet(bytes, cfg.model); }
  std::optional<Scan> decode(const PacketView& packet, Nanos stamp) noexcept;
  void restart() noexcept {
    have_prev = false;
    window_open = false;
    have_seq = false;
    prev_trailing_bad = 0;
    hole.open = 0;
    window_hole.open = 0;
    time_judge.reset();
    scans.clear_rejected();
    turning = false;
    line_shift = 0;
  }

  // Ends the current scan; the hole of late packets was that scan's.
  std::optional<Scan> end(bool complete) noexcept {
    hole.open = 0;
    hole_after_cut = false;
    return scans.end_scan(complete);
  }

  // A silence before this packet (stream_gap.hpp): the scans in progress (and the lookahead past
  // the cut) end as partial, continuity and the UDP sequence start over at this packet; a first
  // group within a packet after the cut begins a whole scan.
  // `unheard_ns`: the silence as the sensor turned (silence_elapsed) where its numbering cannot say
  // whether it sent (IdsAcrossGap::kNone), else 0.
  void new_stream(std::optional<Scan>& out, int first_az, double group_step, int groups, RxTimes rx, Nanos unheard_ns) noexcept {
    ++stats.silences;
    const std::uint32_t rejected = scans.rejected_since_kept();
    const std::uint32_t before = gaps.rejected_before_silence(rx, rejected);
    // The whole turns between the last group heard and this packet's first (no rejected packets in
    // between: those are counted by the scans they began, below). A lookahead past the cut was
    // heard: its scan ends below, counted lost, and is no unheard one.
    if (have_prev && rejected == 0 && unheard_ns > 0) {
      const int to_cut = detail::turn_step(prev_az, emit_raw);
      const std::uint64_t n = scans_unheard(unheard_ns, turn_ns(), detail::turn_step(prev_az, first_az), to_cut == 0 ? detail::kTurn : to_cut);
      stats.scans_unheard += n - std::min<std::uint64_t>(n, scans.next().scan.packets > 0 ? 1 : 0);
    }
    // Packets rejected whole since the last kept one (a frozen encoder) turned on to the next
    // scan's window and past it: the scans they began were made (stream_gap.hpp). A scan begins
    // where its window does (reset_raw); one whose window opened already is the lookahead, ended
    // below with the current one.
    if (have_prev && turning_step >= 0.5)
      scans.lose_scans(detail::scans_begun_before_silence(fov, prev_az, reset_raw, turning_step * groups, before));
    scans.merge(out, end(false));
    if (scans.current().scan.packets > 0) scans.merge(out, end(false));
    scans.drop_next();
    restart();
    const double packet_arc = group_step * groups;
    // Those rejected after the silence are the new stream's: the turns they ended before this packet's.
    if (packet_arc > 0.5) scans.lose_scans(detail::scans_ended_after_silence(fov, reset_raw, first_az, packet_arc, rejected - before));
    scans.current().from_cut = packet_arc > 0.5 && detail::turn_step(emit_raw, first_az) < packet_arc;
  }
  // One turn of the sensor (ns) from the last turning packet's azimuth rate; 0: not known yet.
  [[nodiscard]] Nanos turn_ns() const noexcept {
    if (turning_step < 0.5) return 0;
    return static_cast<Nanos>(detail::kTurn / turning_step * static_cast<double>(mi->group_period_ns));
  }

  // `past_cut_only`: the group's channels past the cut go into the current scan (begun at that cut),
  // the rest nowhere (a late packet of the window after the cut was done).
  void put_group(const std::uint8_t* blk, int a, Nanos group_stamp, bool overlap, int n, std::uint8_t mode, float unit,
                 bool past_cut_only = false);

  // A late packet whose azimuth lies where the current scan counted packets missing: its points go
  // into the scan, an earlier first firing becomes its stamp. Inside the cut's window (still open:
  // the scan before the cut not yet out) its channels past the cut go into the next scan, whose
  // stamp moves back to them as well.
  void place_late(const std::uint8_t* p, const int* az, const detail::AzimuthFit& fit, int groups, int n,
                  std::uint8_t mode, float unit, Nanos stamp, Nanos rx_ns) {
    scans.begin_packet();
    PendingScan& cur = scans.current();
    if (!hole_after_cut) cur.rebase(stamp);
    bool in_next = false, placed = false;
    for (int g = 0; g < groups; ++g) {
      if ((fit.bad >> g) & 1U) continue;
      const Nanos group_stamp = stamp + static_cast<Nanos>(mi->group_period_ns) * g;
      const bool in_window = in_sector(reset_raw, emit_raw, az[g]) && az[g] != emit_raw;
      if (hole_after_cut) {
        // The scan begun at the cut: a group inside the window gives it its channels past the cut,
        // a group past the window all of its own; one before the window is the published scan's.
        const bool past = !in_window && detail::turn_step(emit_raw, az[g]) < detail::kTurn / 2;
        if (!in_window && !past) continue;
        cur.rebase(group_stamp);
        const Nanos last_rx = cur.scan.last_rx_ns;
        cur.touch(group_stamp, rx_ns);
        cur.scan.last_rx_ns = std::max(last_rx, rx_ns);
        put_group(p + mi->first_block + static_cast<std::size_t>(g * n) * mi->block_size, az[g], group_stamp, in_window,
                  n, mode, unit, true);
        placed = true;
        continue;
      }
      const bool overlap = window_open && in_window;
      if (overlap) {
        in_next = true;
        PendingScan& nxt = scans.next();
        nxt.rebase(group_stamp);
        const Nanos nxt_rx = nxt.scan.last_rx_ns;
        nxt.touch(group_stamp, rx_ns);
        nxt.scan.last_rx_ns = std::max(nxt_rx, rx_ns);
      }
      const Nanos last_rx = cur.scan.last_rx_ns;
      cur.touch(group_stamp, rx_ns);
      cur.scan.last_rx_ns = std::max(last_rx, rx_ns);
      put_group(p + mi->first_block + static_cast<std::size_t>(g * n) * mi->block_size, az[g], group_stamp, overlap, n,
                mode, unit);
    }
    if (hole_after_cut && !placed) {  // wholly the published scan's (a gap begun before the window)
      last = scans.drop(PacketStatus::kOutOfOrder);
      return;
    }
    --hole.open;
    scans.fill_missing();
    if (in_next) {
      scans.fill_missing_next();  // counted in both: it has channels in both
      if (window_hole.open > 0) --window_hole.open;
    }
  }
};

// One firing group's points: into the current scan, or (inside the cut's window, `overlap`) the
// channels already past the cut into the next. Shared by the packet loop and late packets.
inline void DecoderImpl::put_group(const std::uint8_t* blk, int a, Nanos group_stamp, bool overlap, int n,
                                   std::uint8_t mode, float unit, bool past_cut_only) {
  const auto& tab = angles();
  const auto rm = static_cast<ReturnMode>(mode);
  const bool xt = cfg.model == Model::kPandarXT32;
  const float thresh = static_cast<float>(cfg.dual_distance_threshold_m);
  const float sa = tab.sin[static_cast<std::size_t>(a)];
  const float ca = tab.cos[static_cast<std::size_t>(a)];
  const std::int64_t a_udeg = static_cast<std::int64_t>(a) * 10'000 - cut_udeg;
  const std::uint8_t* units = blk + mi->block_units;
  for (std::size_t c = 0; c < ch.size(); ++c) {
    const ChannelTable& t = ch[c];
    Scan* s = &scans.scan();
    if (overlap) {
      std::int64_t rel = (a_udeg + t.off_udeg) % kMicroDeg;
      if (rel < 0) rel += kMicroDeg;
      if (rel > kNextScanSpan && past_cut_only) continue;
      if (rel <= kNextScanSpan && !past_cut_only) s = &scans.next().scan;
    }
    const std::uint8_t* u0 = units + c * mi->unit_size;
    const Echo e0{le16(u0), u0[2]};
    if (n == 1) {
      const std::uint8_t type = rm == ReturnMode::kStrongest ? kReturnStrongest
                                : rm == ReturnMode::kLast    ? kReturnLast
                                : rm == ReturnMode::kFirst   ? kReturnFirst
                                                             : kReturnUnknown;
      point(*s, t, e0, unit, sa, ca, group_stamp, type);
      continue;
    }
    const std::uint8_t* u1 = u0 + mi->block_size;
    const Echo e1{le16(u1), u1[2]};
    const bool second_stronger = e1.refl > e0.refl;
    std::uint8_t t0 = kReturnUnknown, t1 = kReturnUnknown;
    int last_idx = e1.raw > e0.raw ? 1 : 0;  // modes without a last echo: the farther one
    switch (rm) {
      case ReturnMode::kLastStrongest:
        t0 = second_stronger ? kReturnLast : kReturnStrongestAndLast;
        t1 = second_stronger ? kReturnStrongest : kReturnSecondStrongest;
        last_idx = 0;
        break;
      case ReturnMode::kFirstLast:  // the XT32 sends the last echo first
        t0 = xt ? kReturnLast : kReturnFirst;
        t1 = xt ? kReturnFirst : kReturnLast;
        last_idx = xt ? 0 : 1;
        break;
      case ReturnMode::kFirstStrongest:
        t0 = kReturnFirst;
        t1 = second_stronger ? kReturnStrongest : kReturnSecondStrongest;
        break;
      default:  // first + second
        t0 = kReturnFirst;
        break;
    }
    switch (cfg.returns) {
      case ReturnSelection::kStrongest:
        if (second_stronger) {
          point(*s, t, e1, unit, sa, ca, group_stamp, t1);
        } else {
          point(*s, t, e0, unit, sa, ca, group_stamp, t0);
        }
        break;
      case ReturnSelection::kLast:
        point(*s, t, last_idx == 0 ? e0 : e1, unit, sa, ca, group_stamp, last_idx == 0 ? t0 : t1);
        break;
      case ReturnSelection::kDual: {
        const bool same = e0.raw == e1.raw && e0.refl == e1.refl;
        const float gap = std::abs(static_cast<float>(e0.raw) - static_cast<float>(e1.raw)) * unit;
        if (!same && !(gap < thresh)) point(*s, t, e0, unit, sa, ca, group_stamp, t0);
        point(*s, t, e1, unit, sa, ca, group_stamp, same && rm == ReturnMode::kLastStrongest ? t0 : t1);
        break;
      }
    }
  }
}

std::optional<Scan> DecoderImpl::decode(const PacketView& packet, Nanos stamp) noexcept {
  const auto* p = reinterpret_cast<const std::uint8_t*>(packet.data.data());
  const std::uint8_t mode = p[mi->tail_return_mode];
  const int n = return_count(mode);
  last_returns = n;
  const float unit = cfg.model == Model::kPandarXT32 ? static_cast<float>(p[offsetof(HeaderXT, dis_unit)]) * 0.001F
                                                     : static_cast<float>(mi->distance_unit_m);
  const int groups = mi->blocks / n;
  int az[16];
  for (int g = 0; g < groups; ++g)
    az[g] = le16(p + mi->first_block + static_cast<std::size_t>(g * n) * mi->block_size + mi->block_azimuth);
  // One corrupted azimuth must not cut the scan: groups off the packet's line are not decoded.
  const detail::AzimuthFit fit = detail::fit_azimuths(az, groups);
  if (fit.good * 2 <= groups) {
    last = scans.drop(PacketStatus::kBadAzimuth);
    return std::nullopt;
  }
  int first_good = 0;
  while ((fit.bad >> first_good) & 1U) ++first_good;
  // Every group at one azimuth while the rotor turns: a frozen encoder. Corrupt, never a scan of
  // its own (a stuck azimuth at the cut made ~377 one-packet scans a second: issue 26 item 7).
  if (groups > 1 && fit.step < 0.5 && have_prev && turning) {
    last = scans.drop(PacketStatus::kBadAzimuth);
    return std::nullopt;
  }
  const std::uint8_t* utc = p + mi->tail_utc;  // year, month, day, hour, minute, second
  const std::int64_t sensor_us = ((static_cast<std::int64_t>(utc[3]) * 60 + utc[4]) * 60 + utc[5]) * 1'000'000 +
                                 static_cast<std::int64_t>(le32(p + mi->tail_timestamp));
  const bool has_seq = packet.data.size() == mi->packet_size_alt || cfg.model == Model::kPandarXT32;
  const std::uint32_t seq = has_seq ? le32(p + packet.data.size() - 4) : 0;

  // Order and duplicates are judged before the time (issue 26 item 1): a late packet is placed
  // or counted, never the end of its scan. One packet whose time jumps while its azimuth (and
  // sequence number) continue is corrupt (item 2); only a sustained step ends the scan. Lost
  // packets: the UDP sequence number where the azimuth and time step agree with it, else the
  // azimuth step (inside the FOV) and the sensor's time step.
  std::optional<Scan> out;
  std::uint32_t missing = 0;
  std::uint32_t slots = 0;  // packet slots between the previous good packet and this one
  const Nanos period_ns = static_cast<Nanos>(mi->group_period_ns) * groups;
  Nanos own = stamp - line_shift;
  // Scans end and none holds the old line's points: the caller's stamps from here on.
  const auto to_caller_line = [&] {
    line_shift = 0;
    own = stamp;
  };
  constexpr std::int64_t kDayUs = 86'400'000'000LL;
  std::int64_t dt_us = sensor_us - prev_sensor_us;
  if (dt_us < -kDayUs / 2) dt_us += kDayUs;
  // Nothing heard for turns while the sensor's time moved on: silent, unless its UDP sequence went
  // on as its time did (then its packets were sent: a loss, counted below). Judged first: nothing
  // before a silence is this packet's order or loss (a restart's sequence begins again).
  if (const Nanos quiet = gaps.quiet_ns(rx_times(packet)); have_prev && quiet > kSilenceTurns * period_ns) {
    const IdsAcrossGap ids =
        has_seq && have_seq
            ? ids_across_gap(prev_seq, seq, 0xFFFF'FFFFU,
                             std::llround(static_cast<double>(dt_us) * 1000.0 / static_cast<double>(period_ns)))
            : IdsAcrossGap::kNone;
    if (is_silence(quiet, turn_ns(), sensor_continues(dt_us * 1000, period_ns), ids)) {
      const Nanos unheard_ns = ids == IdsAcrossGap::kNone ? silence_elapsed(dt_us * 1000, quiet, turn_ns()) : 0;
      new_stream(out, az[first_good], fit.step, groups, rx_times(packet), unheard_ns);
      to_caller_line();
    }
  }
  Nanos lateness_step = -1;  // the sensor's step from the previous kept packet, as loss counts it (-1: none)
  if (have_prev) {
    detail::GapInput in{.prev_az = prev_az,
                        .groups_since_prev = prev_trailing_bad + first_good + 1,
                        .first_az = az[first_good],
                        .group_step = fit.step,
                        .groups_per_packet = groups,
                        .dt_ns = dt_us * 1000,
                        .packet_period_ns = period_ns,
                        .old_packet = detail::old_packet(-dt_us * 1000, period_ns, turn_ns())};
    const StampStep ts = stamp_step(is_time_jump(prev_stamp, stamp, cfg.max_packet_gap_ns, receive_gap(rx_times(packet), prev_rx)),
                                    is_time_jump(0, in.dt_ns, cfg.max_packet_gap_ns, receive_gap(rx_times(packet), prev_rx)));
    const bool jumped = ts.jumped;
    if (ts.mapping_moved) {  // the sensor went on: the scans begun keep their line
      line_shift += stamp - prev_stamp - in.dt_ns;
      own = stamp - line_shift;
      ++stats.mapping_steps;
    }
    // A late packet steps back in time too: placed when within the reorder window.
    const bool far_back = own < prev_own - std::max(kBackwardsTolerance, period_ns * detail::kReorderPackets);
    if (jumped) in.dt_ns = 0;  // a corrupt time must not decide order or loss
    // nor one the receive times refute
    in.dt_ns = sensor_step_within_receive(in.dt_ns, rx_times(packet), prev_rx, lateness.above_floor());
    lateness_step = jumped ? -1 : in.dt_ns;
    auto gap = detail::azimuth_gap(fov, in);
    if (gap.backwards) {  // the azimuth stepped back within the reorder window (packet_order.hpp)
      switch (judge_order({.steps_back = true,
                           .time_moved_on = in.dt_ns > period_ns / 2 && !jumped,
                           .fills_hole = hole.holds(az[first_good]) && (!far_back || in.old_packet)})) {
        case Order::kLate: place_late(p, az, fit, groups, n, mode, unit, own, packet.rx_ns); break;
        case Order::kFrozen: last = scans.drop(PacketStatus::kBadAzimuth); break;
        case Order::kNext:
        case Order::kDuplicate: last = scans.drop(PacketStatus::kOutOfOrder); break;
      }
      return std::nullopt;
    }
    if (gap.implausible) {  // an azimuth its time cannot reach (frozen encoder): corrupt, never a cut
      last = scans.drop(PacketStatus::kBadAzimuth);
      return std::nullopt;
    }
    switch (time_judge.judge(jumped, !gap.resync && gap.missing == 0)) {
      case TimeJudge::Verdict::kOk: break;
      case TimeJudge::Verdict::kCorrupt:
        last = scans.drop(PacketStatus::kBadTime);
        return std::nullopt;
      case TimeJudge::Verdict::kJump:  // a real clock step: the scan ends; continuity starts over
        ++stats.time_jumps;
        scans.merge(out, end(false));
        // The lookahead scan (points already past the cut) will never be completed either.
        if (scans.current().scan.packets > 0) scans.merge(out, end(false));
        scans.drop_next();
        window_hole.open = 0;
        to_caller_line();
        have_prev = false;
        have_seq = false;
        gap = {};
        break;
    }
    missing = gap.missing;
    if (have_prev && gap.resync) {  // a jump back: no cut, nothing missing, continuity from this packet on
      ++stats.implausible_steps;
      have_prev = false;
      have_seq = false;
    }
    if (have_prev && has_seq && have_seq && gap.turns == 0) {
      const std::uint32_t d = seq - prev_seq;
      const std::uint32_t slack = 1 + gap.missing / 8;
      if (d != 0 && d < 0x8000'0000U && (d - 1 <= gap.missing + slack && d - 1 + slack >= gap.missing)) {
        missing = d - 1;
      } else {
        ++stats.sequence_mismatches;
        ++stats.implausible_steps;
      }
    }
    if (have_prev && gap.turns > 0) {
      // Whole turns passed unseen: the scan ends at its cut with what it lacks to there, the turns
      // between are lost scans, the next starts with what it lacks (as the Velodyne decoder).
      const int a0 = az[first_good];
      const bool az_crosses = detail::turn_step(prev_az, emit_raw) > 0 &&
                              detail::turn_step(prev_az, emit_raw) <= detail::turn_step(prev_az, a0);
      // Rejected packets (a frozen azimuth) filled these slots first: dropped, not missing too.
      const auto take = [&](std::uint32_t k) { return scans.missing_beyond_rejected(k); };
      // Every group across the gap, the lost packets' by the sensor's time: their step, for where the
      // boundaries fall (turns_group_step).
      const double gstep = detail::turns_group_step(fov, prev_az, a0, gap.turns,
                                                    prev_trailing_bad + first_good + 1 + static_cast<long>(gap.missing) * groups, fit.step);
      scans.add_missing(take(detail::lost_before(fov, prev_az, emit_raw, gstep, groups, prev_trailing_bad, detail::CrossingGroup::kBoth)));
      // Begun inside the cut's window, the lookahead's turn is lost (lidar/README.md "Whole turns").
      scans.forget_next();
      scans.merge(out, end(scans.current().from_cut));
      window_hole.open = 0;
      window_open = false;
      // The next scan starts at the cut when it lacks less than half its turn; otherwise its
      // stamp (its first packet) would lie nearer the next turn's: not published, a lost scan.
      scans.current().from_cut = 2 * detail::turn_step(emit_raw, a0) < fov.length();
      (void)take(static_cast<std::uint32_t>(std::lround((gap.turns - (az_crosses ? 0 : 1)) * fov.length() /
                                                        std::max(1.0, fit.step * groups))));
      scans.add_missing(take(detail::lost_after(fov, reset_raw, a0, gstep, groups, first_good + 1)));
      scans.lose_scans(gap.turns + (az_crosses ? 1U : 0U) - 1U);
      to_caller_line();
      have_prev = false;
      have_seq = false;
      missing = 0;
    } else if (have_prev) {
      // Packets rejected since the previous good one took slots of the gap: dropped, not missing too.
      slots = missing;
      missing = scans.missing_beyond_rejected(missing);
      const long tol = std::lround(2.0 * fit.step * groups);
      if (missing >= 2) {
        // The gap's packets, the first one group past the last kept.
        const detail::GapPackets lacked{prev_az + fit.step, fit.step * groups, missing};
        if (blind.ended_inside(prev_az, az[first_good], tol, detail::kTurn) ||
            blind.is_blind(prev_az, az[first_good], tol, detail::kTurn, tol / 2, lacked)) {
          missing = 0;
        } else if (const auto* arc = blind.learned_within(prev_az, az[first_good], tol, detail::kTurn)) {
          // A loss burst beside the blind sector: only the burst is loss.
          missing -= std::min(missing, detail::BlindArc::blind_packets(*arc, lacked, detail::kTurn));
        }
      }
    }
  }
  scans.clear_rejected();
  turning = fit.step >= 0.5;
  if (turning) turning_step = fit.step;
  blind.seen(az[first_good], detail::kTurn);
  if (has_seq) {
    prev_seq = have_seq && slots + 1 != seq - prev_seq ? prev_seq + slots + 1 : seq;
    have_seq = true;
  }

  if (lateness_step >= 0) {
    lateness.step(lateness_step, receive_gap(rx_times(packet), prev_rx));
  } else {
    lateness.reset();
  }
  prev_stamp = stamp;
  prev_own = own;
  prev_sensor_us = sensor_us;
  prev_rx = rx_times(packet);
  scans.begin_packet();
  // Packets lost across the cut: those past it are the next scan's (issue 26 item 3).
  // Packets lost inside the cut's window have channels in both scans: missing in both, as a truth
  // record counts them (the next scan hid them: rig chaos, lidar.loss_burst at_cut).
  std::uint32_t missing_next = 0, missing_window = 0;
  if (missing > 0 && have_prev) {
    const int step0 = az_step(prev_az, az[first_good]);
    const double gap_step = detail::gap_group_step(fov, prev_az, az[first_good],
                                                   prev_trailing_bad + first_good + 1 + static_cast<long>(slots) * groups, fit.step);
    // The group crossing the cut is in both scans (as the truth's units count it): a lost packet
    // holding it is the ending scan's too.
    if (crosses(prev_az, step0, emit_raw, true))
      missing_next = missing - detail::split_missing_at_cut(fov, emit_raw, az[first_good], gap_step, first_good + 1, groups,
                                                            missing, detail::CrossingGroup::kBoth).before;
    std::uint32_t touching = 0;
    if (window_open)
      touching = missing;
    else if (crosses(prev_az, step0, reset_raw, true))
      touching = detail::split_missing_at_cut(fov, reset_raw, az[first_good], gap_step, first_good + 1, groups, missing,
                                              detail::CrossingGroup::kBoth).after;
    missing_window = touching > missing_next ? touching - missing_next : 0;
  }
  const int gap_from = prev_az;  // the loop below moves prev_az on
  if (missing > missing_next) {
    scans.add_missing(missing - missing_next);
    hole = {prev_az, az[first_good], detail::kTurn, missing - missing_next};
    hole_after_cut = false;
  }
  if (missing_window > 0) {
    scans.add_missing_next(missing_window);
    window_hole = {prev_az, az[first_good], detail::kTurn, missing_window};
  }
  if (fit.bad != 0) {
    const auto nb = static_cast<std::uint64_t>(std::popcount(fit.bad));
    stats.corrupt_blocks += nb;
    stats.implausible_steps += nb;
    ++scans.scan().dropped;
  }

  for (int g = 0; g < groups; ++g) {
    if ((fit.bad >> g) & 1U) continue;
    const std::uint8_t* blk = p + mi->first_block + static_cast<std::size_t>(g * n) * mi->block_size;
    const int a = az[g];
    const Nanos group_stamp = own + static_cast<Nanos>(mi->group_period_ns) * g;
    bool cut_here = false, crossing_lost = false;
    if (have_prev) {
      const int step = az_step(prev_az, a);
      const bool judged = g == first_good;  // the step from the previous packet (forward, any length)
      if (crosses(prev_az, step, reset_raw, judged)) {
        window_open = true;
        if (!scans.next().started) scans.next().from_cut = true;
      }
      cut_here = crosses(prev_az, step, emit_raw, judged);
      // The group that crosses the cut is in both scans; after a gap across the cut that group was
      // lost, and this one, groups past it, is the next scan's alone (as the truth's units say). Put
      // in both, the first packet after a blind sector across the cut went into the scan before it
      // too: a Pandar40P's scans of 41.7 ms of data spanned 100 ms, their last points the next turn's,
      // and the fused cloud joined them to the next rotation (rig chaos, lidar.blind_sector 338-188).
      crossing_lost = cut_here && judged && step > static_cast<int>(std::lround(1.5 * fit.step));
    } else {
      // First block (or after a time jump) inside the window: the window's start was not seen
      // (channels that passed the cut before it are not in the next scan: it is partial).
      window_open = in_sector(reset_raw, emit_raw, a) && a != emit_raw;
    }
    if (!crossing_lost) {
      const bool overlap = window_open || cut_here;
      if (overlap) scans.next().touch(group_stamp, packet.rx_ns);
      scans.current().touch(group_stamp, packet.rx_ns);
      put_group(blk, a, group_stamp, overlap, n, mode, unit);
    }
    if (cut_here) {
      scans.merge(out, end(scans.current().from_cut));
      window_open = false;
      if (line_shift != 0) {  // the scan on the old line is out: the next moves onto the caller's
        PendingScan& next = scans.current();
        if (next.started) next.scan.stamp += line_shift;
        prev_own += line_shift;
        to_caller_line();
      }
      // The scan begun at the cut lacks what was lost past it and, counted in it while it was the
      // lookahead, what was lost inside the window: a late packet from there is placed in it (its
      // channels past the cut; rig chaos seed 7, a Pandar40P packet of the window one position late
      // behind the packet that closed it: the scan after the cut counted it missing and dropped).
      if (missing_next > 0 || window_hole.open > 0) {
        hole = window_hole.open > 0
                   ? LateHole{window_hole.from, missing_next > 0 ? az[first_good] : window_hole.to, detail::kTurn,
                              window_hole.open + missing_next}
                   : LateHole{gap_from, az[first_good], detail::kTurn, missing_next};
        hole_after_cut = true;
      }
      if (missing_next > 0) {
        scans.add_missing(missing_next);
        missing_next = 0;
      }
      window_hole.open = 0;
    }
    if (crossing_lost) {  // after the cut: the next scan's alone
      scans.current().touch(group_stamp, packet.rx_ns);
      put_group(blk, a, group_stamp, false, n, mode, unit);
    }
    have_prev = true;
    prev_az = a;
  }
  int last_good = groups - 1;
  while ((fit.bad >> last_good) & 1U) --last_good;
  prev_trailing_bad = groups - 1 - last_good;
  return out;
}

Decoder::Decoder(DecoderConfig config) : DecoderPimpl(std::move(config)) {}

Nanos Decoder::first_firing_offset_ns(int returns) const noexcept {
  const int groups = impl().mi->blocks / std::max(returns, 1);
  return static_cast<Nanos>(impl().mi->tail_to_last_group_ns) -
         static_cast<Nanos>(impl().mi->group_period_ns) * (groups - 1) + impl().min_fire_ns;
}
int Decoder::last_returns() const noexcept { return impl().last_returns; }
std::uint16_t Decoder::ring_of_channel(int channel) const noexcept {
  if (channel < 1 || channel > impl().mi->channels) return 0;
  return impl().ring_of_channel[static_cast<std::size_t>(channel - 1)];
}

}  // namespace sensor_rig::lidar::hesai

namespace sensor_rig::lidar {
template class DecoderPimpl<hesai::DecoderImpl, hesai::DecoderConfig, hesai::DecoderStats>;
}  // namespace sensor_rig::lidar
