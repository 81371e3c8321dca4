// Velodyne decoder: packet validation, scan assembly and the per-point hot loop.
// Geometry (ROS velodyne / VeloView model): with azimuth a (clockwise from the front, minus the
// laser's rotation correction), elevation v, distance d, vertical offset vo and horizontal
// offset ho, the sensor frame (x right, y forward, z up) is
//   xy = d cos v - vo sin v;  x = xy sin a - ho cos a;  y = xy cos a + ho sin a;  z = d sin v + vo cos v
// and REP 103 is (y, -x, z).
#include "sensor_rig/lidar/velodyne/decoder.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "angle_table.hpp"
#include "sensor_rig/lidar/detail/azimuth_continuity.hpp"
#include "sensor_rig/lidar/detail/decoder_pimpl_impl.hpp"
#include "sensor_rig/lidar/packet_order.hpp"
#include "sensor_rig/lidar/packet_time.hpp"
#include "sensor_rig/lidar/stream_gap.hpp"

namespace sensor_rig::lidar::velodyne {
namespace {

constexpr int kAzimuthCount = 36000;
constexpr std::uint8_t kLegacyProductId = 0x21;  // sent by HDL-32E and by early VLP-16 firmware

struct ChannelTable {
  float cos_v, sin_v;
  float xy_off;  // -vo sin v
  float z_off;   // vo cos v
  float cos_r, sin_r;
  float ho;
  float dist_corr;
  std::uint32_t t_ns;        // firing offset within the block
  std::uint32_t az_frac_q16; // t_ns / block duration, 16-bit fixed point (azimuth interpolation)
  float az_frac;             // the same as a float (per-laser azimuth, angle addition)
  std::uint16_t ring;
};

inline std::uint16_t rd16(const std::uint8_t* p) noexcept { return le16(p); }

// Forward azimuth step from a to b in hundredths of a degree, in [0, 36000).
inline int az_step(int a, int b) noexcept {
  const int d = b - a;
  return d < 0 ? d + kAzimuthCount : d;
}

ScanAssemblerOptions scan_options(const DecoderConfig& cfg) {
  const std::size_t dual = cfg.returns == ReturnSelection::kDual ? 2 : 1;
  const std::size_t typical = static_cast<std::size_t>(model_info(cfg.model).typical_points_per_scan) * dual;
  return {.first_reserve = cfg.first_scan_reserve_points != 0 ? cfg.first_scan_reserve_points : typical,
          .emit_partial_scans = cfg.emit_partial_scans};
}

}  // namespace

PacketStatus check_packet(std::span<const std::byte> bytes, Model m) noexcept {
  if (bytes.size() != kDataPacketSize) {
    return bytes.size() == kPositionPacketSize ? PacketStatus::kNotData : PacketStatus::kWrongSize;
  }
  const auto* p = reinterpret_cast<const std::uint8_t*>(bytes.data());
  for (std::size_t b = 0; b < kBlocksPerPacket; ++b) {
    const std::uint8_t* blk = p + b * sizeof(RawBlock);
    if (rd16(blk) != kBlockFlagUpper) return PacketStatus::kBadBlockFlag;
    // 36000 (360.00°) is sent by real sensors at the wrap; it means 0° but ends the revolution.
    if (rd16(blk + 2) > kAzimuthCount) return PacketStatus::kBadAzimuth;
  }
  const std::uint8_t mode = p[offsetof(RawDataPacket, return_mode)];
  const std::uint8_t pid = p[offsetof(RawDataPacket, product_id)];
  const bool mode_ok = mode == 0 || mode == static_cast<std::uint8_t>(ReturnMode::kStrongest) ||
                       mode == static_cast<std::uint8_t>(ReturnMode::kLast) ||
                       mode == static_cast<std::uint8_t>(ReturnMode::kDual);
  const bool pid_ok =
      pid == 0 || pid == kLegacyProductId || pid == static_cast<std::uint8_t>(model_info(m).product_id);
  return mode_ok && pid_ok ? PacketStatus::kOk : PacketStatus::kWrongModel;
}

struct DecoderImpl {
  DecoderConfig cfg;
  const ModelInfo* info = nullptr;
  std::array<ChannelTable, kChannelsPerBlock> ch{};
  alignas(32) std::array<float, kChannelsPerBlock> laser_frac{};  // ch[c].az_frac, contiguous (SIMD)
  std::array<std::uint16_t, kChannelsPerBlock> ring_of_laser{};
  float resolution = 0.002F;
  float min_range = 0.0F;
  float max_range = 0.0F;
  int cut = 0;  // hundredths of a degree
  std::uint32_t block_ns = 0;

  DecoderStats stats;
  PacketStatus last = PacketStatus::kOk;
  ScanAssembler scans;
  bool have_prev = false;
  // The scan was already ended after the previous packet (its next block was predicted to cross
  // the cut): the crossing seen at the next packet's first block is not a second cut.
  bool early_cut = false;
  bool skip_to_cut = false;  // this packet's groups before the cut belong to a turn counted lost whole
  int prev_az = 0;
  int last_gap = 0;  // azimuth advance of the last decoded block (hundredths of a degree)
  Nanos prev_stamp = 0;
  RxTimes prev_rx;  // the previous packet's receive time (0: none)
  detail::AzimuthFov fov;
  int prev_trailing_bad = 0;       // groups after prev_az in the previous packet that were corrupt
  std::uint32_t prev_sensor_us = 0;  // the previous packet's own time (µs since the hour)
  LateHole hole;                     // where the current scan last counted packets missing
  TimeJudge time_judge;
  bool turning = false;  // the last good packet's azimuth advanced: a frozen one is a fault
  detail::BlindArc blind;  // a sector the sensor stopped sending (learned, not loss)
  StreamGap gaps;           // when the sensor was last heard (a silence is no loss)
  ArrivalLateness lateness;  // how late the last kept packet came (a held network's queue drains at once)
  double turning_step = 0;  // azimuth per group of the last turning packet (0.01°): the turn's length

  explicit DecoderImpl(DecoderConfig config)
      : cfg(std::move(config)), info(&model_info(cfg.model)), scans(scan_options(cfg), stats) {
    if (!(cfg.min_range_m >= 0.0) || !(cfg.max_range_m > cfg.min_range_m)) {
      throw std::invalid_argument("range: need 0 <= min_range (" + std::to_string(cfg.min_range_m) +
                                  ") < max_range (" + std::to_string(cfg.max_range_m) + ")");
    }
    if (!(cfg.cut_angle_deg >= 0.0 && cfg.cut_angle_deg < 360.0)) {
      throw std::invalid_argument("cut angle " + std::to_string(cfg.cut_angle_deg) + " is not in [0, 360)");
    }
    if (cfg.max_packet_gap_ns <= 0) throw std::invalid_argument("max_packet_gap_ns must be positive");
    const Calibration cal = validate_for_model(
        cfg.calibration ? *cfg.calibration : default_calibration(cfg.model), cfg.model);
    cfg.calibration = cal;
    resolution = static_cast<float>(cal.distance_resolution_m);
    min_range = static_cast<float>(cfg.min_range_m);
    max_range = std::isinf(cfg.max_range_m) ? std::numeric_limits<float>::max()
                                            : static_cast<float>(cfg.max_range_m);
    cut = static_cast<int>(std::lround(cfg.cut_angle_deg * 100.0)) % kAzimuthCount;
    block_ns = static_cast<std::uint32_t>(std::lround(info->block_us * 1000.0));
    if (!(cfg.fov_start_deg >= 0.0 && cfg.fov_start_deg <= 360.0 && cfg.fov_end_deg >= 0.0 && cfg.fov_end_deg <= 360.0))
      throw std::invalid_argument("fov: start and end must be in [0, 360] degrees");
    fov = detail::make_fov(cfg.fov_start_deg, cfg.fov_end_deg);

    // Ring = rank by elevation (ties by laser id), 0 = lowest.
    std::vector<int> order(static_cast<std::size_t>(info->lasers));
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return cal.lasers[static_cast<std::size_t>(a)].vert_correction <
             cal.lasers[static_cast<std::size_t>(b)].vert_correction;
    });
    for (std::size_t r = 0; r < order.size(); ++r)
      ring_of_laser[static_cast<std::size_t>(order[r])] = static_cast<std::uint16_t>(r);

    for (int c = 0; c < static_cast<int>(kChannelsPerBlock); ++c) {
      const int laser = channel_laser(cfg.model, c);
      const auto& l = cal.lasers[static_cast<std::size_t>(laser)];
      auto& t = ch[static_cast<std::size_t>(c)];
      const double cv = std::cos(l.vert_correction);
      const double sv = std::sin(l.vert_correction);
      t.cos_v = static_cast<float>(cv);
      t.sin_v = static_cast<float>(sv);
      t.xy_off = static_cast<float>(-l.vert_offset_correction * sv);
      t.z_off = static_cast<float>(l.vert_offset_correction * cv);
      t.cos_r = static_cast<float>(std::cos(l.rot_correction));
      t.sin_r = static_cast<float>(std::sin(l.rot_correction));
      t.ho = static_cast<float>(l.horiz_offset_correction);
      t.dist_corr = static_cast<float>(l.dist_correction);
      t.t_ns = channel_offset_ns(cfg.model, c);
      // Firing-sequence start of this channel (VLP-16: two sequences per block), or its own firing.
      const std::uint32_t interp_ns = cfg.interpolation == AzimuthInterpolation::kPerLaser
                                          ? t.t_ns
                                          : channel_offset_ns(cfg.model, c - c % info->lasers);
      t.az_frac_q16 = static_cast<std::uint32_t>((static_cast<std::uint64_t>(interp_ns) << 16) / block_ns);
      t.az_frac = static_cast<float>(static_cast<double>(interp_ns) / static_cast<double>(block_ns));
      laser_frac[static_cast<std::size_t>(c)] = t.az_frac;
      t.ring = ring_of_laser[static_cast<std::size_t>(laser)];
    }
  }

  // Azimuth sin/cos per channel of a block: one lookup per firing sequence (VeloView
  // interpolation) or one per laser.
  struct BlockAngles {
    float sa[kChannelsPerBlock];
    float ca[kChannelsPerBlock];
  };
  void block_angles(int az, std::uint32_t gap, BlockAngles& out) const noexcept {
    if (cfg.interpolation == AzimuthInterpolation::kPerLaser) {
      // Block azimuth from the table, each laser's advance d (< 1°) by angle addition with
      // sin d = d - d³/6, cos d = 1 - d²/2 (error < 1e-9 rad): no per-laser table lookup (a
      // gather the compiler cannot vectorize) and no 0.01° rounding of the laser's azimuth.
      constexpr float kRadPerCenti = static_cast<float>(std::numbers::pi / 18000.0);
      const float sa0 = kAngles.sin[static_cast<std::size_t>(az % kAzimuthCount)];
      const float ca0 = kAngles.cos[static_cast<std::size_t>(az % kAzimuthCount)];
      const float g = static_cast<float>(gap) * kRadPerCenti;
      for (std::size_t c = 0; c < kChannelsPerBlock; ++c) {
        const float d = g * laser_frac[c];
        const float d2 = d * d;
        const float sd = d - d * d2 * (1.0F / 6.0F);
        const float cd = 1.0F - 0.5F * d2;
        out.sa[c] = sa0 * cd + ca0 * sd;
        out.ca[c] = ca0 * cd - sa0 * sd;
      }
      return;
    }
    const std::size_t per_seq = static_cast<std::size_t>(info->lasers);
    for (std::size_t c0 = 0; c0 < kChannelsPerBlock; c0 += per_seq) {
      int a = az + static_cast<int>((gap * ch[c0].az_frac_q16 + 0x8000U) >> 16);
      if (a >= kAzimuthCount) a -= kAzimuthCount;
      const float sa = kAngles.sin[static_cast<std::size_t>(a)];
      const float ca = kAngles.cos[static_cast<std::size_t>(a)];
      for (std::size_t c = c0; c < c0 + per_seq; ++c) {
        out.sa[c] = sa;
        out.ca[c] = ca;
      }
    }
  }

  inline void emit(const ChannelTable& t, std::uint16_t raw, std::uint8_t intensity, float sa, float ca,
                   std::uint32_t t_base, std::uint8_t rtype) {
    const float d = static_cast<float>(raw) * resolution + t.dist_corr;
    if (raw == 0 || d < min_range || d > max_range) return;
    const float sr = sa * t.cos_r - ca * t.sin_r;
    const float cr = ca * t.cos_r + sa * t.sin_r;
    const float xy = d * t.cos_v + t.xy_off;
    const float xv = xy * sr - t.ho * cr;
    const float yv = xy * cr + t.ho * sr;
    scans.scan().points.push_back(PointXYZIRT{yv, -xv, d * t.sin_v + t.z_off, static_cast<float>(intensity),
                                              t_base + t.t_ns, t.ring, rtype, 0});
  }

  // One firing group's points into the current scan (its t after the scan's stamp: t_base); returns
  // the group's azimuth advance (0: not interpolated). Shared by the packet loop and late packets.
  [[gnu::always_inline]] inline std::uint32_t put_group(const std::uint8_t* p, int k, int b, const int* az,
                                                        const detail::AzimuthFit& fit, int groups, bool dual,
                                                        std::uint8_t single_type, std::uint32_t t_base) {
    const int a = az[k];
    // Azimuth advance over this block: to the next block, or from the previous one for the last
    // (a packet with a corrupted block: the fitted step).
    std::uint32_t agap = 0;
    if (fit.bad != 0) {
      agap = static_cast<std::uint32_t>(std::lround(fit.step));
    } else {
      agap = static_cast<std::uint32_t>(k + 1 < groups ? az_step(a, az[k + 1]) : az_step(az[k - 1], a));
    }
    if (agap > 1000) agap = 0;  // not a plausible rotation step: do not interpolate

    BlockAngles ang;
    block_angles(a, agap, ang);
    const std::uint8_t* e = p + static_cast<std::size_t>(b) * sizeof(RawBlock) + 4;
    if (!dual) {
      for (std::size_t c = 0; c < kChannelsPerBlock; ++c) {
        emit(ch[c], rd16(e + 3 * c), e[3 * c + 2], ang.sa[c], ang.ca[c], t_base, single_type);
      }
      return agap;
    }
    const std::uint8_t* o = e + sizeof(RawBlock);
    for (std::size_t c = 0; c < kChannelsPerBlock; ++c) {
      const std::uint16_t d_even = rd16(e + 3 * c);
      const std::uint16_t d_odd = rd16(o + 3 * c);
      const std::uint8_t i_even = e[3 * c + 2];
      const std::uint8_t i_odd = o[3 * c + 2];
      // Even block: last echo. Odd block: strongest, or the second strongest when the last echo
      // is also the strongest; the same distance in both means one echo reported twice.
      const bool same = d_even == d_odd;
      const bool odd_strongest = !same && i_odd > i_even;
      const std::uint8_t te = odd_strongest ? kReturnLast : kReturnStrongestAndLast;
      const std::uint8_t to = odd_strongest ? kReturnStrongest : kReturnSecondStrongest;
      switch (cfg.returns) {
        case ReturnSelection::kLast:
          emit(ch[c], d_even, i_even, ang.sa[c], ang.ca[c], t_base, te);
          break;
        case ReturnSelection::kStrongest:
          if (odd_strongest) {
            emit(ch[c], d_odd, i_odd, ang.sa[c], ang.ca[c], t_base, to);
          } else {
            emit(ch[c], d_even, i_even, ang.sa[c], ang.ca[c], t_base, te);
          }
          break;
        case ReturnSelection::kDual:
          emit(ch[c], d_even, i_even, ang.sa[c], ang.ca[c], t_base, te);
          if (!same) emit(ch[c], d_odd, i_odd, ang.sa[c], ang.ca[c], t_base, to);
          break;
      }
    }
    return agap;
  }

  // Ends the current scan; the hole of late packets was that scan's.
  std::optional<Scan> end(bool complete, bool next_from_cut = false) noexcept {
    hole.open = 0;
    return scans.end_scan(complete, next_from_cut);
  }

  // A late packet whose azimuth lies where the current scan counted packets missing: its points go
  // into the scan (an earlier first firing becomes the scan's stamp) and the count goes down.
  void place_late(const std::uint8_t* p, const int* az, const detail::AzimuthFit& fit, int groups, int step, bool dual,
                  std::uint8_t single_type, Nanos stamp, Nanos rx_ns) {
    scans.begin_packet();
    PendingScan& cur = scans.current();
    bool rebased = false;
    for (int k = 0; k < groups; ++k) {
      // Only the groups inside the hole: a late packet across the cut has its earlier ones in the
      // scan already published (a drop there, not here).
      if (((fit.bad >> k) & 1U) != 0 || !hole.holds(az[k] == kAzimuthCount ? kAzimuthCount - 1 : az[k])) continue;
      const Nanos block_stamp = stamp + static_cast<Nanos>(k) * block_ns;
      if (!rebased) {
        cur.rebase(block_stamp);
        rebased = true;
      }
      const Nanos last_rx = cur.scan.last_rx_ns;
      cur.touch(block_stamp, rx_ns);
      cur.scan.last_rx_ns = std::max(last_rx, rx_ns);
      const auto t_base = static_cast<std::uint32_t>(block_stamp - cur.scan.stamp);
      (void)put_group(p, k, k * step, az, fit, groups, dual, single_type, t_base);
    }
    --hole.open;
    scans.fill_missing();
  }

  PacketStatus check(std::span<const std::byte> bytes) const noexcept { return check_packet(bytes, cfg.model); }
  std::optional<Scan> decode(const PacketView& packet, Nanos stamp) noexcept;
  void restart() noexcept {
    have_prev = false;
    early_cut = false;
    prev_trailing_bad = 0;
    hole.open = 0;
    time_judge.reset();
    scans.clear_rejected();
    turning = false;
  }

  // A silence before this packet (stream_gap.hpp): the scan in progress ends as partial, continuity
  // starts over at this packet; a first group within a packet after the cut begins a whole scan.
  // `elapsed_ns`: the silence as the sensor turned (silence_elapsed), `turn`: one turn (ns).
  std::optional<Scan> new_stream(int first_az, double group_step, int groups, RxTimes rx, Nanos elapsed_ns, Nanos turn) noexcept {
    ++stats.silences;
    const std::uint32_t rejected = scans.rejected_since_kept();
    const std::uint32_t before = gaps.rejected_before_silence(rx, rejected);
    // The whole turns between the last group heard and this packet's first (no rejected packets
    // in between: those are counted by the scans they began, below).
    if (have_prev && rejected == 0) {
      const int to_cut = detail::turn_step(prev_az, cut);
      stats.scans_unheard += scans_unheard(elapsed_ns, turn, detail::turn_step(prev_az, first_az), to_cut == 0 ? detail::kTurn : to_cut);
    }
    // Packets rejected whole since the last kept one (a frozen encoder) turned on to the cut and
    // past it: the scans they began were made (stream_gap.hpp). Packet k after the last kept one
    // reaches the cut when its last group does.
    if (have_prev && turning_step >= 0.5)
      scans.lose_scans(detail::scans_begun_before_silence(fov, prev_az, cut, turning_step * groups, before));
    std::optional<Scan> out = end(false);
    restart();
    const double packet_arc = group_step * groups;
    // Those rejected after the silence are the new stream's: the turns they ended before this packet's.
    if (packet_arc > 0.5) scans.lose_scans(detail::scans_ended_after_silence(fov, cut, first_az, packet_arc, rejected - before));
    scans.current().from_cut = packet_arc > 0.5 && detail::turn_step(cut, first_az) < packet_arc;
    return out;
  }
  // One turn of the sensor (ns) from the last turning packet's azimuth rate; 0: not known yet.
  [[nodiscard]] Nanos turn_ns(Nanos packet_period_ns, int groups) const noexcept {
    if (turning_step < 0.5) return 0;
    return static_cast<Nanos>(kAzimuthCount / turning_step * static_cast<double>(packet_period_ns) / groups);
  }
};

std::optional<Scan> DecoderImpl::decode(const PacketView& packet, Nanos stamp) noexcept {
  const auto* p = reinterpret_cast<const std::uint8_t*>(packet.data.data());
  const std::uint8_t mode = p[offsetof(RawDataPacket, return_mode)];
  const bool dual = mode == static_cast<std::uint8_t>(ReturnMode::kDual);
  const std::uint8_t single_type = mode == static_cast<std::uint8_t>(ReturnMode::kLast)        ? kReturnLast
                                   : mode == static_cast<std::uint8_t>(ReturnMode::kStrongest) ? kReturnStrongest
                                                                                              : kReturnUnknown;
  const int step = dual ? 2 : 1;
  const int groups = static_cast<int>(kBlocksPerPacket) / step;  // firing groups (dual: block pairs)
  int az[kBlocksPerPacket];
  int na[kBlocksPerPacket];  // reduced to [0, 36000) for the fit
  for (int k = 0; k < groups; ++k) {
    az[k] = rd16(p + static_cast<std::size_t>(k * step) * sizeof(RawBlock) + 2);
    na[k] = az[k] == kAzimuthCount ? 0 : az[k];
  }
  // One corrupted azimuth must not cut the scan: groups off the packet's line are not decoded.
  const detail::AzimuthFit fit = detail::fit_azimuths(na, groups);
  if (fit.good * 2 <= groups) {  // no line at all: the packet is garbage
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
  const std::uint32_t sensor_us = le32(p + offsetof(RawDataPacket, timestamp));

  // Order and duplicates are judged before the time: a late packet is placed or counted, never
  // the end of its scan (issue 26 item 1). Then one packet whose time jumps while its azimuth
  // continues is corrupt (item 2); only a sustained step ends the scan.
  std::optional<Scan> out;
  Nanos lateness_step = -1;  // the sensor's step from the previous kept packet, as loss counts it (-1: none)
  detail::GapResult gap{};
  std::uint32_t gap_slots = 0;  // packet slots of the gap: lost and rejected
  const Nanos period_ns = static_cast<Nanos>(block_ns) * groups;
  constexpr std::int64_t kHourUs = 3'600'000'000LL;
  std::int64_t dt_us = static_cast<std::int64_t>(sensor_us) - prev_sensor_us;
  if (dt_us < -kHourUs / 2) dt_us += kHourUs;
  // Nothing heard for turns while the sensor's time moved on: it was silent, not a loss (no ids
  // to say otherwise). Judged first: nothing before a silence is this packet's order or loss.
  if (const Nanos quiet = gaps.quiet_ns(rx_times(packet)); have_prev && quiet > kSilenceTurns * period_ns &&
      is_silence(quiet, turn_ns(period_ns, groups), sensor_continues(dt_us * 1000, period_ns), IdsAcrossGap::kNone)) {
    const Nanos turn = turn_ns(period_ns, groups);
    out = new_stream(na[first_good], fit.step, groups, rx_times(packet), silence_elapsed(dt_us * 1000, quiet, turn), turn);
  }
  if (have_prev) {
    detail::GapInput in{.prev_az = prev_az,
                        .groups_since_prev = prev_trailing_bad + first_good + 1,
                        .first_az = na[first_good],
                        .group_step = fit.step,
                        .groups_per_packet = groups,
                        .dt_ns = dt_us * 1000,
                        .packet_period_ns = period_ns,
                        .old_packet = detail::old_packet(-dt_us * 1000, period_ns, turn_ns(period_ns, groups))};
    // Its stamps are its sensor time (µs since the hour, mapped): both jump alike, no mapping step.
    const bool stamps_jumped = is_time_jump(prev_stamp, stamp, cfg.max_packet_gap_ns, receive_gap(rx_times(packet), prev_rx));
    const bool jumped = stamp_step(stamps_jumped, stamps_jumped).jumped;
    // A late packet steps back in time too: placed when within the reorder window.
    const bool far_back = stamp < prev_stamp - std::max(kBackwardsTolerance, period_ns * detail::kReorderPackets);
    if (jumped) in.dt_ns = 0;  // a corrupt time must not decide order or loss
    // nor one the receive times refute
    in.dt_ns = sensor_step_within_receive(in.dt_ns, rx_times(packet), prev_rx, lateness.above_floor());
    lateness_step = jumped ? -1 : in.dt_ns;
    gap = detail::azimuth_gap(fov, in);
    if (gap.backwards) {  // the azimuth stepped back within the reorder window (packet_order.hpp)
      int last_good_k = groups - 1;
      while ((fit.bad >> last_good_k) & 1U) --last_good_k;
      switch (judge_order({.steps_back = true,
                           .time_moved_on = in.dt_ns > period_ns / 2 && !jumped,
                           .fills_hole = (hole.holds(na[first_good]) || hole.holds(na[last_good_k])) && (!far_back || in.old_packet)})) {
        case Order::kLate: place_late(p, az, fit, groups, step, dual, single_type, stamp, packet.rx_ns); break;
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
        out = end(false);
        have_prev = false;
        gap = {};
        break;
    }
    if (have_prev && gap.resync) {  // a jump back: no cut, nothing missing, continuity from this packet on
      ++stats.implausible_steps;
      have_prev = false;
      gap = {};
    }
    if (have_prev && gap.turns > 0) {
      // Whole turns passed unseen (packets lost or rejected): the scan ends at its cut with what it
      // lacks to there, the turns between are lost scans, the next starts with what it lacks.
      const int a0 = na[first_good];
      const bool az_crosses = detail::turn_step(prev_az, cut) > 0 && detail::turn_step(prev_az, cut) <= detail::turn_step(prev_az, a0);
      // The gap ended just before a cut this packet crosses: the turn it ended in is lost whole
      // (all but this packet's groups before the cut, left out), the next scan begins at the cut.
      // Begun at a0 instead, that scan held the lost turn's tail, went unpublished as not begun at
      // a cut, and its turn was counted nowhere (a burst of 1.05 turns from 2 packets before a cut).
      int last_good_k = groups - 1;
      while ((fit.bad >> last_good_k) & 1U) --last_good_k;
      const bool cut_in_packet = !az_crosses && detail::turn_step(a0, cut) > 0 &&
                                 detail::turn_step(a0, cut) <= detail::turn_step(a0, na[last_good_k]);
      // Rejected packets (a frozen azimuth) filled these slots first: dropped, not missing too.
      const auto take = [&](std::uint32_t k) { return scans.missing_beyond_rejected(k); };
      // Every group across the gap, the lost packets' by the sensor's time: their step, for where the
      // boundaries fall (turns_group_step).
      const double gstep = detail::turns_group_step(fov, prev_az, a0, gap.turns,
                                                    prev_trailing_bad + first_good + 1 + static_cast<long>(gap.missing) * groups, fit.step);
      if (!early_cut) scans.add_missing(take(detail::lost_before(fov, prev_az, cut, gstep, groups, prev_trailing_bad)));
      // The next scan starts at the cut when it lacks less than half its turn; otherwise its
      // stamp (its first packet) would lie nearer the next turn's: not published, a lost scan.
      const bool next_whole = cut_in_packet || 2 * detail::turn_step(cut, a0) < fov.length();
      out = end(scans.current().from_cut, next_whole);
      (void)take(static_cast<std::uint32_t>(std::lround((gap.turns - (az_crosses ? 0 : 1)) * fov.length() /
                                                        std::max(1.0, fit.step * groups))));
      if (!cut_in_packet) scans.add_missing(take(detail::lost_after(fov, cut, a0, gstep, groups, first_good + 1)));
      scans.lose_scans(gap.turns + (az_crosses || cut_in_packet ? 1U : 0U) - 1U);
      skip_to_cut = cut_in_packet;
      have_prev = false;  // the cut is done: the first group opens the new scan
      gap = {};
    } else if (have_prev) {
      // Packets rejected since the previous good one took slots of the gap: dropped, not missing too.
      gap_slots = gap.missing;
      gap.missing = scans.missing_beyond_rejected(gap.missing);
      const long tol = std::lround(2.0 * fit.step * groups);
      if (gap.missing >= 2) {
        // The gap's packets, the first one group past the last kept.
        const detail::GapPackets lacked{prev_az + fit.step, fit.step * groups, gap.missing};
        if (blind.ended_inside(prev_az, na[first_good], tol, detail::kTurn) ||
            blind.is_blind(prev_az, na[first_good], tol, detail::kTurn, tol / 2, lacked)) {
          gap.missing = 0;
        } else if (const auto* arc = blind.learned_within(prev_az, na[first_good], tol, detail::kTurn)) {
          // A loss burst beside the blind sector: only the burst is loss.
          gap.missing -= std::min(gap.missing, detail::BlindArc::blind_packets(*arc, lacked, detail::kTurn));
        }
      }
    }
  }
  scans.clear_rejected();
  turning = fit.step >= 0.5;
  if (turning) turning_step = fit.step;
  blind.seen(na[first_good], detail::kTurn);

  if (lateness_step >= 0) {
    lateness.step(lateness_step, receive_gap(rx_times(packet), prev_rx));
  } else {
    lateness.reset();
  }
  prev_stamp = stamp;
  prev_sensor_us = sensor_us;
  prev_rx = rx_times(packet);
  scans.begin_packet();
  if (fit.bad != 0) {
    const auto n = static_cast<std::uint32_t>(std::popcount(fit.bad));
    stats.corrupt_blocks += n;
    stats.implausible_steps += n;
    ++scans.scan().dropped;
  }

  for (int k = 0; k < groups; ++k) {
    if ((fit.bad >> k) & 1U) continue;
    const int b = k * step;
    const int a = az[k];
    // For the cut, 360.00° is the last position of the revolution (VeloView splits after it).
    const int a_cut = a == kAzimuthCount ? kAzimuthCount - 1 : a;
    if (skip_to_cut && detail::turn_step(na[first_good], a_cut) < detail::turn_step(na[first_good], cut)) continue;
    skip_to_cut = false;
    if (have_prev && !out) {
      // The first group's step was judged by azimuth_gap (forward, whatever its length: lost
      // packets, the FOV's blind arc); later steps inside a packet are on the fitted line.
      const int s = az_step(prev_az, a_cut);
      const bool plausible = k == first_good || s < kAzimuthCount / 2;
      const bool crosses = plausible && s > 0 && az_step(prev_az, cut) > 0 && az_step(prev_az, cut) <= s;
      bool cut_done = false;
      if (k == first_good && gap.missing > 0) {
        // Packets lost across the cut: those past it belong to the next scan, one across it to both.
        detail::CutSplit split{gap.missing, 0};
        if (crosses && !early_cut) {
          const long gap_groups = prev_trailing_bad + k + 1 + static_cast<long>(gap_slots) * groups;
          const double gstep = detail::gap_group_step(fov, prev_az, na[k], gap_groups, fit.step);
          split = detail::split_missing_at_cut(fov, cut, na[k], gstep, k + 1, groups, gap.missing,
                                               detail::CrossingGroup::kNextOnly);  // the crossing group starts it
        }
        scans.add_missing(split.before);
        hole = {prev_az, a_cut, detail::kTurn, split.before};
        if (crosses && !early_cut) {
          out = end(scans.current().from_cut, true);
          scans.add_missing(split.after);
          hole = {cut == 0 ? detail::kTurn - 1 : cut - 1, a_cut, detail::kTurn, split.after};  // past the cut only
          cut_done = true;
        }
      }
      if (!cut_done && early_cut) {
        if (!crosses) ++stats.early_cut_misses;  // prediction wrong: this block joined the new scan early
      } else if (!cut_done && crosses) {
        out = end(scans.current().from_cut, true);
      }
    }
    early_cut = false;
    have_prev = true;
    prev_az = a_cut;
    const Nanos block_stamp = stamp + static_cast<Nanos>(k) * block_ns;
    scans.current().touch(block_stamp, packet.rx_ns);
    const auto t_base = static_cast<std::uint32_t>(block_stamp - scans.scan().stamp);
    last_gap = static_cast<int>(put_group(p, k, b, az, fit, groups, dual, single_type, t_base));
  }
  int last_good = groups - 1;
  while ((fit.bad >> last_good) & 1U) --last_good;
  prev_trailing_bad = groups - 1 - last_good;
  // End the scan now when the next block will cross the cut: waiting for the next packet to show
  // it would add one packet interval (1.3 ms on a VLP-16) to every scan's latency. A margin of
  // two hundredths of a degree keeps azimuth jitter from making the prediction wrong.
  constexpr int kEarlyCutMargin = 2;
  if (!out && have_prev && last_gap > 0 && prev_trailing_bad == 0) {
    const int to_cut = az_step(prev_az, cut);
    if (to_cut > 0 && to_cut + kEarlyCutMargin <= last_gap) {
      out = end(scans.current().from_cut, true);
      early_cut = true;
    }
  }
  return out;
}

Decoder::Decoder(DecoderConfig config) : DecoderPimpl(std::move(config)) {}

std::uint16_t Decoder::ring_of_laser(int laser_id) const noexcept {
  if (laser_id < 0 || laser_id >= impl().info->lasers) return 0;
  return impl().ring_of_laser[static_cast<std::size_t>(laser_id)];
}

}  // namespace sensor_rig::lidar::velodyne

namespace sensor_rig::lidar {
template class DecoderPimpl<velodyne::DecoderImpl, velodyne::DecoderConfig, velodyne::DecoderStats>;
}  // namespace sensor_rig::lidar
