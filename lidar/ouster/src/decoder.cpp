// Ouster decoder: packet validation, scan assembly by frame id, and the per-pixel hot loop.
#include "sensor_rig/lidar/ouster/decoder.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include "sensor_rig/lidar/ouster/packet.hpp"
#include "sensor_rig/lidar/detail/azimuth_continuity.hpp"
#include "sensor_rig/lidar/detail/decoder_pimpl_impl.hpp"
#include "sensor_rig/lidar/packet_order.hpp"
#include "sensor_rig/lidar/packet_time.hpp"
#include "sensor_rig/lidar/stream_gap.hpp"
#include "pixel_reader.hpp"
#include "profile_table.hpp"
#include "xyz_lut.hpp"

namespace sensor_rig::lidar::ouster {
namespace {

const SensorMetadata& validated(const DecoderConfig& c) {
  const auto& m = c.metadata;
  if (!(c.min_range_m >= 0.0) || !(c.max_range_m > c.min_range_m))
    throw std::invalid_argument("range: need 0 <= min_range (" + std::to_string(c.min_range_m) + ") < max_range (" +
                                std::to_string(c.max_range_m) + ")");
  if (c.max_packet_gap_ns <= 0) throw std::invalid_argument("max_packet_gap_ns must be positive");
  if (m.pixels_per_column <= 0 || m.columns_per_frame <= 0 || m.columns_per_packet <= 0 ||
      m.columns_per_packet > m.columns_per_frame || !(m.frames_per_second > 0.0))
    throw std::invalid_argument("metadata: data format is not set (use parse_metadata)");
  const auto n = static_cast<std::size_t>(m.pixels_per_column);
  if (m.beam_altitude_deg.size() != n || m.beam_azimuth_deg.size() != n)
    throw std::invalid_argument("metadata: need one beam altitude and azimuth angle per pixel");
  if (m.column_window_first < 0 || m.column_window_first >= m.columns_per_frame || m.column_window_last < 0 ||
      m.column_window_last >= m.columns_per_frame)
    throw std::invalid_argument("metadata: column window outside the frame");
  return m;
}

std::uint32_t to_mm(double m, bool round_up) {
  const double mm = m * 1000.0;
  if (!(mm < 4e9)) return std::numeric_limits<std::uint32_t>::max();
  return static_cast<std::uint32_t>(round_up ? std::ceil(mm) : std::floor(mm));
}

std::uint32_t clamp_u32(Nanos v) noexcept {
  if (v <= 0) return 0;
  return v >= static_cast<Nanos>(std::numeric_limits<std::uint32_t>::max()) ? std::numeric_limits<std::uint32_t>::max()
                                                                            : static_cast<std::uint32_t>(v);
}

// A full frame is the most a scan can hold (Ouster scans are cut by frame id).
ScanAssemblerOptions scan_options(const DecoderConfig& c) {
  const bool dual = profile_spec(c.metadata.profile).returns == 2;
  const std::size_t full = static_cast<std::size_t>(c.metadata.columns_per_frame) *
                           static_cast<std::size_t>(c.metadata.pixels_per_column) *
                           (dual && c.returns == ReturnSelection::kDual ? 2 : 1);
  return {.first_reserve = full, .max_reserve = full, .emit_partial_scans = c.emit_partial_scans};
}

// Writes a column's points: every pixel is written, and only a range inside [lo_mm, lo_mm + span_mm]
// advances the count (no per-point branch: no-return pixels are frequent and scattered).
struct ColumnWriter {
  PointXYZIRT* out;  // room for two points per pixel
  std::size_t n;
  std::uint64_t lo_mm;
  std::uint64_t span_mm;
  std::uint32_t t;

  void add(const LutEntry& l, std::uint64_t r, std::uint64_t i, std::uint16_t rg, std::uint8_t type) noexcept {
    const float f = static_cast<float>(static_cast<std::uint32_t>(r));  // fields are < 32 bits
    out[n] = PointXYZIRT{l.dx * f + l.ox, l.dy * f + l.oy, l.dz * f + l.oz,
                         static_cast<float>(static_cast<std::uint32_t>(i)), t, rg, type, 0};
    n += (r - lo_mm <= span_mm) ? 1 : 0;
  }
};

// The single-return column loop with profile P's pixel layout as constants (from the profile
// table at compile time: constant offsets, shifts, masks and stride). Returns the point count.
// Works on a local copy of the writer: one the points' byte stores might alias would be reloaded
// per point (and a writer passed or returned by value stalls on store forwarding per column).
template <Profile P, Field Intensity>
std::size_t decode_single(const std::uint8_t* px, const LutEntry* l, const std::uint16_t* ring, std::size_t h,
                          const ColumnWriter& start) noexcept {
  ColumnWriter w = start;
  constexpr const ProfileSpec& kSpec = kProfileTable[static_cast<std::size_t>(P)];
  constexpr PixelReader kRange(kSpec.fields[static_cast<std::size_t>(Field::kRange)]);
  constexpr PixelReader kIntensity(kSpec.fields[static_cast<std::size_t>(Intensity)]);
  for (std::size_t r = 0; r < h; ++r, px += kSpec.pixel_bytes)
    w.add(l[r], kRange.read(px), kIntensity.read(px), ring[r], kReturnStrongest);
  return w.n;
}

using SingleColumnFn = std::size_t (*)(const std::uint8_t*, const LutEntry*, const std::uint16_t*, std::size_t,
                                       const ColumnWriter&);

template <Profile P>
SingleColumnFn single_column_for(bool signal) {
  return signal ? &decode_single<P, Field::kSignal> : &decode_single<P, Field::kReflectivity>;
}

// nullptr for the dual-return profiles (decode_dual reads them through the runtime readers).
SingleColumnFn single_column_for(Profile p, bool signal) {
  switch (p) {
    case Profile::kLegacy: return single_column_for<Profile::kLegacy>(signal);
    case Profile::kRng19Rfl8Sig16Nir16: return single_column_for<Profile::kRng19Rfl8Sig16Nir16>(signal);
    case Profile::kRng15Rfl8Nir8: return single_column_for<Profile::kRng15Rfl8Nir8>(signal);
    case Profile::kRng15Rfl8Win8: return single_column_for<Profile::kRng15Rfl8Win8>(signal);
    default: return nullptr;
  }
}

}  // namespace

struct DecoderImpl {
  DecoderConfig cfg;
  PacketLayout layout;
  XyzLut lut;
  std::vector<std::uint16_t> ring;  // per beam
  PixelReader range, range2, inten, inten2;
  bool dual = false;
  SingleColumnFn single_column = nullptr;  // the single-return profiles' column loop
  std::uint64_t lo_mm = 1;    // a point's range r (mm) is kept when r - lo_mm <= span_mm (unsigned):
  std::uint64_t span_mm = 0;  // lo_mm >= 1 drops range 0 (no return)
  std::vector<PointXYZIRT> column_points;  // one column's points (both returns) before they join the scan
  std::uint32_t window_first = 0;  // first column of a frame that carries data
  std::uint32_t window_last = 0;   // last one
  Nanos span_ns = 0;
  std::vector<ColumnHeader> cols;  // this packet's column headers
  std::vector<std::uint8_t> col_ok;

  DecoderStats stats;
  PacketStatus last = PacketStatus::kOk;
  ScanAssembler scans;  // current().from_cut: the scan began at the frame's first packet
  bool have_stamp = false;
  Nanos prev_stamp = 0;
  // The caller's mapping of sensor time may move while the sensor's clock goes on (a host
  // CLOCK_REALTIME step: the mapping follows the host, a PTP-synced sensor does not). The stamp
  // jumps, the column times do not: that is no time jump (it cost the scan in progress and a dropped
  // packet), and the scan goes on on the line it began on: vehicle minus sensor time at its first
  // packet (scan_offset). A time jump is both clocks jumping (a sensor clock step, a corrupt column
  // time the stamper mapped); the sensor's alone is a replay's loop under host stamps, as before.
  Nanos scan_offset = 0;
  bool have_offset = false;
  Nanos prev_own = 0;      // the previous packet on its scan's line
  bool mapping_moved = false;  // this scan's later packets are on its line, not the caller's stamps
  bool have_fid = false;
  std::uint32_t prev_fid = 0;
  bool have_base = false;
  long prev_base = 0;          // measurement id of the previous packet's column 0
  std::uint64_t prev_ts = 0;   // its first valid column's sensor time
  RxTimes prev_rx;             // ... and its receive time (0: none)
  long packets_per_frame = 1;
  LateHole hole;                // packet slots where the current scan last counted packets missing
  TimeJudge time_judge;
  detail::BlindArc blind;  // packet slots the sensor stopped sending (learned, not loss)
  StreamGap gaps;  // when the sensor was last heard (a silence is no loss)
  ArrivalLateness lateness;  // how late the last kept packet came (a held network's queue drains at once)

  // Packet slots strictly between slot `from` and slot `to` of one frame (to > from) that hold
  // columns of the column window (the sensor's FOV: only those can be missing).
  [[nodiscard]] std::uint32_t window_slots(long from, long to) const noexcept {
    const long cpp = static_cast<long>(layout.columns_per_packet);
    long n = 0;
    for (long i = from + 1; i < to; ++i)
      if ((i + 1) * cpp - 1 >= static_cast<long>(window_first) && i * cpp <= static_cast<long>(window_last)) ++n;
    return static_cast<std::uint32_t>(n);
  }

  explicit DecoderImpl(DecoderConfig config)
      : cfg(std::move(config)), layout(validated(cfg).layout()), lut(cfg.metadata), scans(scan_options(cfg), stats) {
    const auto& m = cfg.metadata;
    const auto& spec = profile_spec(m.profile);
    dual = spec.returns == 2;
    if (layout.col_header_size < PixelReader::kMinBytesBefore) throw std::logic_error("ouster: column header too short");
    const auto reader = [&](Field f) { return PixelReader(spec.field(f)); };
    range = reader(Field::kRange);
    range2 = reader(Field::kRange2);
    const bool use_signal = cfg.intensity == IntensitySource::kSignal && spec.has(Field::kSignal);
    inten = reader(use_signal ? Field::kSignal : Field::kReflectivity);
    inten2 = reader(use_signal ? Field::kSignal2 : Field::kReflectivity2);
    if (!dual) {
      single_column = single_column_for(m.profile, use_signal);
      if (single_column == nullptr) throw std::logic_error("ouster: no column loop for profile " + std::string(spec.name));
    }
    const std::uint64_t min_mm = std::max<std::uint64_t>(1, to_mm(cfg.min_range_m, true));
    const std::uint64_t max_mm =
        std::isinf(cfg.max_range_m) ? std::numeric_limits<std::uint32_t>::max() : to_mm(cfg.max_range_m, false);
    // An empty interval (both limits rounded inside one millimetre) keeps nothing: no field reaches 2^32.
    lo_mm = max_mm >= min_mm ? min_mm : std::uint64_t{1} << 32;
    span_mm = max_mm >= min_mm ? max_mm - min_mm : 0;
    column_points.resize(layout.pixels_per_column * 2);
    const bool wraps = m.column_window_first > m.column_window_last;
    window_first = wraps ? 0U : static_cast<std::uint32_t>(m.column_window_first);
    window_last = static_cast<std::uint32_t>(wraps ? m.columns_per_frame - 1 : m.column_window_last);
    span_ns = static_cast<Nanos>(std::llround(m.column_period_ns() * static_cast<double>(m.columns_per_packet)));
    packets_per_frame = static_cast<long>((m.columns_per_frame + m.columns_per_packet - 1) / m.columns_per_packet);
    cols.resize(layout.columns_per_packet);
    col_ok.resize(layout.columns_per_packet);

    // Ring = rank of the beam's altitude, 0 = lowest (ties by beam index).
    std::vector<std::size_t> order(m.beam_altitude_deg.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return m.beam_altitude_deg[a] < m.beam_altitude_deg[b]; });
    ring.resize(order.size());
    for (std::size_t r = 0; r < order.size(); ++r) ring[order[r]] = static_cast<std::uint16_t>(r);
  }

  void decode_dual(const std::uint8_t* px, const LutEntry& l, std::uint16_t rg, ColumnWriter& w) const {
    const std::uint64_t r1 = range.read(px);
    const std::uint64_t r2 = range2.read(px);
    if (r1 == 0 && r2 == 0) return;
    const std::uint64_t i1 = inten.read(px);
    const std::uint64_t i2 = inten2.read(px);
    // Which of the (up to) two echoes is the strongest and which the farthest.
    int strongest = r1 != 0 ? 1 : 2;
    if (r1 != 0 && r2 != 0 && cfg.metadata.return_order != ReturnOrder::kStrongestFirst) strongest = i2 > i1 ? 2 : 1;
    const int farthest = r2 > r1 ? 2 : 1;
    const auto type = [&](int k) -> std::uint8_t {
      if (k == strongest) return k == farthest ? kReturnStrongestAndLast : kReturnStrongest;
      return k == farthest ? kReturnLast : kReturnSecondStrongest;
    };
    switch (cfg.returns) {
      case ReturnSelection::kStrongest:
        if (strongest == 1) w.add(l, r1, i1, rg, type(1)); else w.add(l, r2, i2, rg, type(2));
        break;
      case ReturnSelection::kLast:
        if (farthest == 1) w.add(l, r1, i1, rg, type(1)); else w.add(l, r2, i2, rg, type(2));
        break;
      case ReturnSelection::kDual:
        w.add(l, r1, i1, rg, type(1));
        w.add(l, r2, i2, rg, type(2));
        break;
    }
  }

  // One column into the column buffer (the profile's compiled loop, or decode_dual), then onto the
  // scan in one copy (a buffer of a whole packet, one copy per packet, measured slower: it leaves L1).
  void decode_column(const std::uint8_t* col, std::uint16_t mid, std::uint32_t t) {
    const LutEntry* l = lut.column(mid);
    const std::uint8_t* px = col + layout.col_header_size;
    const std::size_t h = layout.pixels_per_column;
    const std::uint16_t* rg = ring.data();
    ColumnWriter w{column_points.data(), 0, lo_mm, span_mm, t};
    if (single_column != nullptr) {
      w.n = single_column(px, l, rg, h, w);
    } else {
      for (std::size_t r = 0; r < h; ++r, px += layout.pixel_size) decode_dual(px, l[r], rg[r], w);
    }
    auto& points = scans.scan().points;
    points.insert(points.end(), column_points.begin(), column_points.begin() + static_cast<std::ptrdiff_t>(w.n));
  }

  PacketStatus check(std::span<const std::byte> bytes) const noexcept { return check_packet(bytes, layout); }
  std::optional<Scan> decode(const PacketView& packet, Nanos stamp) noexcept;
  void restart() noexcept {
    have_fid = false;
    have_stamp = false;
    have_offset = false;
    mapping_moved = false;
    have_base = false;
    hole.open = 0;
    time_judge.reset();
    scans.clear_rejected();
  }

  // Ends the current scan; the hole of late packets was that scan's.
  std::optional<Scan> end(bool complete) noexcept {
    hole.open = 0;
    return scans.end_scan(complete);
  }

  // A silence before this packet (stream_gap.hpp): the scan in progress ends as partial, frame
  // and packet continuity start over at this packet (a frame from its first column is whole).
  std::optional<Scan> new_stream(long slot, RxTimes rx) noexcept {
    ++stats.silences;
    const std::uint32_t rejected = scans.rejected_since_kept();
    const std::uint32_t before = gaps.rejected_before_silence(rx, rejected);
    const double per_frame = window_slots(-1, packets_per_frame);
    // Packets rejected whole since the last kept one (no column to place them by: frozen
    // measurement ids) filled the frame's window slots and went on into later frames: the frames
    // they began were made (stream_gap.hpp). The next frame begins at its window's first slot.
    if (have_base) {
      const long prev_slot = prev_base >= 0 ? prev_base / static_cast<long>(layout.columns_per_packet) : 0;
      scans.lose_scans(scans_begun_while_rejected(before, window_slots(prev_slot, packets_per_frame) + 1.0, per_frame));
    }
    // Those rejected after the silence are the new stream's: the frames they ended before this
    // packet's were made (the window slots before `slot` are this frame's, begun partial).
    scans.lose_scans(scans_ended_while_rejected(rejected - before, window_slots(-1, slot), per_frame));
    std::optional<Scan> out = end(false);
    restart();
    return out;
  }
  [[nodiscard]] Nanos frame_ns() const noexcept {
    return static_cast<Nanos>(static_cast<double>(cfg.metadata.columns_per_frame) * cfg.metadata.column_period_ns());
  }
  // Whole frames the column times say passed beyond the `ahead` (0 or 1) frames of the measurement
  // ids from packet slot `prev_slot` to `slot`, `dt` ns later.
  [[nodiscard]] long extra_frames(long prev_slot, long slot, long ahead, std::int64_t dt) const noexcept {
    const double col_ns = cfg.metadata.column_period_ns();
    const double expected = static_cast<double>((ahead * packets_per_frame + slot - prev_slot) *
                                                static_cast<long>(layout.columns_per_packet)) *
                            col_ns;
    const double frame = static_cast<double>(cfg.metadata.columns_per_frame) * col_ns;
    return frame > 0.0 ? std::max(0L, std::lround((static_cast<double>(dt) - expected) / frame)) : 0;
  }
};

std::optional<Scan> DecoderImpl::decode(const PacketView& packet, Nanos stamp) noexcept {
  const auto* p = reinterpret_cast<const std::uint8_t*>(packet.data.data());
  const auto& m = cfg.metadata;
  if (m.init_id != 0 && layout.header != HeaderType::kLegacy) {
    const auto id = FieldReader::from(header_spec(layout.header).init_id).read(p);
    if (id != m.init_id) ++stats.init_id_mismatches;
  }

  // Column headers first: the packet's first column on the majority line of its measurement ids
  // (id = base + column) gives its time and frame position (issue 26 item 5); a column off it is
  // corrupt: not decoded, counted (bad_measurement_ids, the scan's dropped). A packet with no
  // majority (a frozen encoder: every id alike) is dropped whole.
  std::size_t n_valid = 0;
  std::uint64_t first_ts = 0;
  long base = 0;  // measurement id of the packet's first column
  bool damaged = false;
  bool one_line = true;
  const long cpp_cols = static_cast<long>(layout.columns_per_packet);
  for (std::size_t c = 0; c < layout.columns_per_packet; ++c) {
    cols[c] = column_header_at(p + layout.column_offset(c), layout);
    col_ok[c] = 0;
    if (!cols[c].valid()) {
      ++stats.invalid_columns;
    } else if (cols[c].measurement_id >= m.columns_per_frame) {
      ++stats.bad_measurement_ids;
      damaged = true;
    } else {
      col_ok[c] = 1;
      const long b = static_cast<long>(cols[c].measurement_id) - static_cast<long>(c);
      if (n_valid++ == 0) {
        first_ts = cols[c].timestamp_ns;
        base = b;
      } else if (b != base) {
        one_line = false;
      }
    }
  }
  if (!one_line) {
    long best = base;
    std::size_t best_n = 0;
    for (std::size_t c = 0; c < layout.columns_per_packet; ++c) {
      if (col_ok[c] == 0) continue;
      const long b = static_cast<long>(cols[c].measurement_id) - static_cast<long>(c);
      std::size_t k = 0;
      for (std::size_t j = 0; j < layout.columns_per_packet; ++j)
        k += col_ok[j] != 0 && static_cast<long>(cols[j].measurement_id) - static_cast<long>(j) == b ? 1 : 0;
      if (k > best_n) {
        best_n = k;
        best = b;
      }
    }
    if (best_n * 2 <= n_valid || best % cpp_cols != 0) {
      last = scans.drop(PacketStatus::kBadAzimuth);
      return std::nullopt;
    }
    base = best;
    n_valid = 0;
    for (std::size_t c = 0; c < layout.columns_per_packet; ++c) {
      if (col_ok[c] == 0) continue;
      if (static_cast<long>(cols[c].measurement_id) - static_cast<long>(c) != base) {
        col_ok[c] = 0;
        ++stats.bad_measurement_ids;
        ++stats.implausible_steps;
        damaged = true;
      } else if (n_valid++ == 0) {
        first_ts = cols[c].timestamp_ns;
      }
    }
  }
  // An invalid column inside the column window is a damaged column (outside it the sensor sends none).
  for (std::size_t c = 0; c < layout.columns_per_packet; ++c) {
    const long at = base + static_cast<long>(c);
    if (!cols[c].valid() && n_valid > 0 && at >= static_cast<long>(window_first) && at <= static_cast<long>(window_last))
      damaged = true;
  }
  // No column to place the packet by: every measurement id off the frame, or every column's status
  // invalid (damaged: the sensor sends no packet wholly outside its column window). Rejected whole
  // (it takes its slot: dropped, not missing too), never a packet of its scan (issue 26 item 7);
  // counted as one of its scan's packets before, while the gap it seemed to leave counted it missing.
  if (n_valid == 0) {
    last = scans.drop(PacketStatus::kBadAzimuth);
    return std::nullopt;
  }

  std::optional<Scan> out;
  const std::uint32_t fid = frame_id_at(p, layout);
  const long cpp = static_cast<long>(layout.columns_per_packet);
  const long slot = base >= 0 ? base / cpp : 0;
  // Nothing heard for frames while the column times moved on: silent, unless the frame id went on
  // as the times did (then its frames were sent: a loss, counted below). Judged first: nothing
  // before a silence is this packet's order or loss (a restart's frame ids begin again).
  if (const Nanos quiet = gaps.quiet_ns(rx_times(packet));
      n_valid > 0 && have_base && have_fid && quiet > kSilenceTurns * span_ns) {
    const auto dt = static_cast<std::int64_t>(first_ts - prev_ts);
    const long prev_slot = prev_base >= 0 ? prev_base / cpp : 0;
    const long ahead = slot > prev_slot ? 0 : 1;
    const IdsAcrossGap ids = dt > 0 ? ids_across_gap(prev_fid, fid, 0xFFFFU, ahead + extra_frames(prev_slot, slot, ahead, dt))
                                    : IdsAcrossGap::kRestarted;
    if (is_silence(quiet, frame_ns(), sensor_continues(dt, span_ns), ids)) out = new_stream(slot, rx_times(packet));
  }
  // The packet on the current scan's line (unsigned: a corrupt column time wraps, as the ids' do).
  // A packet without column times (0) has only the caller's stamp.
  const bool on_line = have_offset && first_ts != 0;
  const Nanos own = on_line ? static_cast<Nanos>(first_ts + static_cast<std::uint64_t>(scan_offset)) : stamp;
  // Order and duplicates are judged before the time (issue 26 item 1): a late packet is placed in
  // the hole it left or counted, never the end of its scan. Then one packet whose time jumps while
  // its measurement ids continue the previous packet's is corrupt (item 2); a sustained step ends
  // the scan. Frame and packet continuity: the measurement ids say where in the frame a packet is; a
  // frame id that changes while they continue the frame is corrupted (counted, not a cut); a frame
  // that starts (ids wrap) with the frame id unchanged is a new frame if its time is later (a
  // corrupted frame id), else a late packet. Lost packets: the window's packet slots skipped, plus
  // whole frames the column times say were skipped.
  bool late = false;
  if (n_valid > 0 && have_base && have_fid) {
    const auto dt = static_cast<std::int64_t>(first_ts - prev_ts);
    const double reorder_ns = 16.0 * static_cast<double>(cpp) * m.column_period_ns();  // 16 packets
    // Duplicate or late: its columns fired before the previous packet's (within the reorder window),
    // wherever its slot lies: the previous frame's last packet arriving after the next frame's first
    // has a higher slot (it was taken for a new frame, and ended the one just begun). Negated as a
    // double: dt may be INT64_MIN.
    // Its column times are its position: no time of its own moves on while they step back.
    // Farther back than that, within half a frame: an old packet all the same (sent again, or held),
    // not a restart or a replay looping: lidar/detail/azimuth_continuity.hpp old_packet().
    const bool old = dt < 0 && -2.0 * static_cast<double>(dt) < static_cast<double>(frame_ns());
    switch (judge_order({.steps_back = (dt <= 0 && -static_cast<double>(dt) <= reorder_ns) || old,
                         .time_moved_on = false,
                         .fills_hole = fid == prev_fid && hole.holds(slot)})) {
      case Order::kNext: break;
      case Order::kLate: late = true; break;  // placed below, continuity untouched
      case Order::kFrozen:
      case Order::kDuplicate: last = scans.drop(PacketStatus::kOutOfOrder); return out;
    }
  }
  if (n_valid > 0 && !late) {
    const bool stamp_jumped = have_stamp && is_time_jump(prev_stamp, stamp, cfg.max_packet_gap_ns, receive_gap(rx_times(packet), prev_rx));
    const bool sensor_jumped = !on_line || is_time_jump(prev_own, own, cfg.max_packet_gap_ns, receive_gap(rx_times(packet), prev_rx));
    const StampStep ts = stamp_step(stamp_jumped, sensor_jumped);
    const bool jumped = ts.jumped;
    if (ts.mapping_moved) {
      mapping_moved = true;
      ++stats.mapping_steps;
    }
    bool continues = false;
    if (have_base && have_fid) {
      const long prev_slot = prev_base >= 0 ? prev_base / cpp : 0;
      continues = slot == prev_slot + 1 || (slot == 0 && prev_slot == packets_per_frame - 1);
    }
    switch (time_judge.judge(jumped, continues)) {
      case TimeJudge::Verdict::kOk: break;
      case TimeJudge::Verdict::kCorrupt:
        last = scans.drop(PacketStatus::kBadTime);
        return out;
      case TimeJudge::Verdict::kJump:
        ++stats.time_jumps;
        out = end(false);
        have_fid = false;
        break;
    }
    prev_stamp = stamp;
    prev_own = own;
    have_stamp = true;
  }
  bool new_frame = have_fid && fid != prev_fid && !late;
  std::uint32_t missing_before = 0, missing_after = 0;
  bool opened = false;  // this packet opened a hole (a gap before it, inside its frame)
  Nanos lateness_step = -1;  // the sensor's step from the previous kept packet, as loss counts it (-1: none)
  if (n_valid > 0 && have_base && have_fid && !late) {
    const long prev_slot = prev_base >= 0 ? prev_base / cpp : 0;
    const auto dt = sensor_step_within_receive(static_cast<std::int64_t>(first_ts - prev_ts), rx_times(packet), prev_rx,
                                               lateness.above_floor());
    lateness_step = dt > 0 ? dt : -1;
    const long ahead = slot > prev_slot ? 0 : 1;  // frames ahead by the measurement ids
    if (dt <= 0) {  // a jump back in time (sensor restart, a looping replay): continuity starts over
      ++stats.implausible_steps;
    } else {
      // Whole frames lost in between: the column times say more than the ids do.
      const long extra = extra_frames(prev_slot, slot, ahead, dt);
      if (ahead == 0 && extra == 0) {
        if (new_frame) ++stats.implausible_steps;  // frame id corrupted: the same frame goes on
        new_frame = false;
        missing_before = window_slots(prev_slot, slot);
        if (missing_before >= 2 && scans.rejected_since_kept() == 0) {
          // Packet slots: the gap's packets are the slots after the last kept one, a slot each.
          const detail::GapPackets lacked{static_cast<double>(prev_slot + 1), 1.0, missing_before};
          if (blind.ended_inside(prev_slot, slot, 2, packets_per_frame) ||
              blind.is_blind(prev_slot, slot, 2, packets_per_frame, 0, lacked)) {
            missing_before = 0;
          } else if (const auto* arc = blind.learned_within(prev_slot, slot, 2, packets_per_frame)) {
            // A loss burst beside the blind sector: only the burst is loss.
            missing_before -= std::min(missing_before, detail::BlindArc::blind_packets(*arc, lacked, packets_per_frame));
          }
        }
        if (missing_before > 0) {
          hole = {prev_slot, slot, 0, missing_before};
          opened = true;
        }
      } else {
        if (!new_frame) ++stats.implausible_steps;  // a new frame with the frame id unchanged: corrupted
        new_frame = true;
        missing_before = window_slots(prev_slot, packets_per_frame);
        // Frames skipped whole are lost scans, not missing packets of the next one.
        missing_after = window_slots(-1, slot);
        if (ahead + extra > 1) scans.lose_scans(static_cast<std::uint64_t>(ahead + extra - 1));
        // A gap across the frame's end alone: held against the blind arcs as one on the frame's
        // cycle of slots (a sector across the cut; before, never learned: rig chaos seed 4 with
        // drawn parameters, 43 phantom packets a turn). A loss beside such an arc counts whole.
        if (ahead + extra == 1 && missing_before + missing_after >= 2 && scans.rejected_since_kept() == 0) {
          const detail::GapPackets lacked{static_cast<double>(prev_slot + 1), 1.0, missing_before + missing_after};
          if (blind.is_blind(prev_slot, slot, 2, packets_per_frame, 0, lacked)) missing_before = missing_after = 0;
        }
      }
    }
    // Packets rejected since the previous good one took slots of the gap: dropped, not missing too.
    missing_before = scans.missing_beyond_rejected(missing_before);
    missing_after = scans.missing_beyond_rejected(missing_after);
    // Only the gap this packet opened shrinks: a packet that continues its predecessor leaves the
    // hole open for the late packet still to come (lidar.reorder n > 1).
    if (opened) hole.open = missing_before;
  }
  if (!late) scans.clear_rejected();
  if (!late && n_valid > 0) blind.seen(slot, packets_per_frame);
  if (n_valid > 0 && !late) {
    if (lateness_step >= 0) {
      lateness.step(lateness_step, receive_gap(rx_times(packet), prev_rx));
    } else {
      lateness.reset();
    }
    have_base = true;
    prev_base = base;
    prev_ts = first_ts;
    prev_rx = rx_times(packet);
  }
  PendingScan& cur = scans.current();
  if (late) {
    --hole.open;
    scans.fill_missing();
    cur.rebase(mapping_moved ? own : stamp);
  }
  if (missing_before > 0) scans.add_missing(missing_before);
  if (new_frame && cur.scan.packets > 0) out = end(cur.from_cut);
  if (missing_after > 0) {
    scans.add_missing(missing_after);
    hole = {-1, slot, 0, missing_after};  // the new frame's first slots
  }
  if (cur.scan.packets == 0) {
    // A frame whose first half was lost is not published (its stamp, its first packet's, would lie
    // nearer the next frame's): at its end it is a lost scan.
    cur.from_cut = (new_frame && (missing_after == 0 || 2 * slot < packets_per_frame)) ||
                   (n_valid > 0 && base <= static_cast<long>(window_first));
    cur.scan.first_rx_ns = packet.rx_ns;
  }
  ++cur.scan.packets;
  cur.scan.last_rx_ns = std::max(cur.scan.last_rx_ns, packet.rx_ns);
  if (damaged) ++cur.scan.dropped;
  if ((!have_fid || new_frame) && !late) prev_fid = fid;  // a corrupted frame id is not remembered
  have_fid = true;
  if (n_valid == 0) return out;

  if (!cur.started) {
    cur.scan.stamp = stamp;
    cur.started = true;
    // A new scan takes the mapping as it is now.
    scan_offset = static_cast<Nanos>(static_cast<std::uint64_t>(stamp) - first_ts);
    have_offset = true;
    mapping_moved = false;
    if (!late) prev_own = stamp;
  }
  const Nanos at = mapping_moved && on_line ? own : stamp;
  // Saturating: a corrupt timestamp (fuzz_ouster's find) made these sums overflow int64 (UB).
  const auto saturate = [](bool overflowed, Nanos v, Nanos sign) {
    return overflowed ? (sign >= 0 ? std::numeric_limits<Nanos>::max() : std::numeric_limits<Nanos>::min()) : v;
  };
  Nanos t_packet = 0;
  const bool packet_overflow = __builtin_sub_overflow(at, cur.scan.stamp, &t_packet);
  t_packet = saturate(packet_overflow, t_packet, at);
  for (std::size_t c = 0; c < layout.columns_per_packet; ++c) {
    if (col_ok[c] == 0) continue;
    const auto dt = static_cast<Nanos>(cols[c].timestamp_ns - first_ts);  // wraps for a column before the first
    Nanos t = 0;
    const bool overflow = __builtin_add_overflow(t_packet, dt, &t);  // sequenced before t is read
    t = saturate(overflow, t, dt);
    decode_column(p + layout.column_offset(c), cols[c].measurement_id, clamp_u32(t));
  }
  // The frame's last packet ends the scan now instead of with the next frame's first packet.
  const long last_col = base + static_cast<long>(layout.columns_per_packet) - 1;
  if (!out && !late && last_col >= static_cast<long>(window_last)) out = end(cur.from_cut);
  return out;
}

Decoder::Decoder(DecoderConfig config) : DecoderPimpl(std::move(config)) {}

const PacketLayout& Decoder::layout() const noexcept { return impl().layout; }
Nanos Decoder::packet_span_ns() const noexcept { return impl().span_ns; }

std::uint16_t Decoder::ring_of_beam(std::size_t beam) const noexcept {
  return beam < impl().ring.size() ? impl().ring[beam] : 0;
}

std::optional<std::uint64_t> Decoder::first_column_time(std::span<const std::byte> bytes) const noexcept {
  const auto& d = impl();
  if (check_packet(bytes, d.layout) != PacketStatus::kOk) return std::nullopt;
  const auto* p = reinterpret_cast<const std::uint8_t*>(bytes.data());
  for (std::size_t c = 0; c < d.layout.columns_per_packet; ++c) {
    const auto h = column_header_at(p + d.layout.column_offset(c), d.layout);
    if (h.valid() && h.measurement_id < d.cfg.metadata.columns_per_frame) return h.timestamp_ns;
  }
  return std::nullopt;
}

}  // namespace sensor_rig::lidar::ouster

namespace sensor_rig::lidar {
template class DecoderPimpl<ouster::DecoderImpl, ouster::DecoderConfig, ouster::DecoderStats>;
}  // namespace sensor_rig::lidar
