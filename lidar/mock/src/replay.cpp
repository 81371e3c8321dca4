#include "sensor_rig/lidar/mock/replay.hpp"

#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <vector>

#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/lidar/pcap_reader.hpp"
#include "sensor_rig/lidar/ouster/imu_packet.hpp"
#include "sensor_rig/lidar/velodyne/packet.hpp"

namespace sensor_rig::lidar::mock {
namespace {

constexpr Nanos kLateNs = 1'000'000;
constexpr Nanos kSleepSliceNs = 100'000'000;  // wake up at least this often to check for shutdown
constexpr Nanos kSpinNs = 20'000;             // deadlines closer than this are not slept for

// Sleeps until the absolute monotonic deadline; false when a shutdown was requested meanwhile.
bool sleep_until(Nanos deadline) noexcept {
  while (true) {
    if (shutdown_requested()) return false;
    const Nanos now = monotonic_now_ns();
    if (now >= deadline) return true;
    const Nanos until = std::min(deadline, now + kSleepSliceNs);
    timespec ts{static_cast<time_t>(until / 1'000'000'000LL), static_cast<long>(until % 1'000'000'000LL)};
    const int rc = ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
    if (rc != 0 && rc != EINTR) return true;
  }
}

// What the rate faults did to one packet, from their counters (they keep no per-packet record).
void report_rate_fates(ReplayObserver& obs, std::int64_t tag, const FaultStats& a, const FaultStats& b) {
  using truth::Fate;
  if (b.dropped > a.dropped) obs.fate(tag, Fate::kDropped, 0);
  if (b.truncated > a.truncated) obs.fate(tag, Fate::kTruncated, 0);
  if (b.corrupted > a.corrupted) obs.fate(tag, Fate::kCorrupted, 0);
  if (b.reordered > a.reordered) obs.fate(tag, Fate::kDelayed, 0);
  if (b.duplicated > a.duplicated) obs.fate(tag, Fate::kDuplicated, 0);
}

void report_decisions(ReplayObserver* obs, ScheduledFaults& s) {
  if (obs != nullptr)
    for (const NetDecision& d : s.decisions()) obs->fate(d.tag, d.fate, d.fault);
  s.decisions().clear();
}

}  // namespace

PcapStream::PcapStream(std::string path) : path_(std::move(path)), reader_(std::make_unique<PcapReader>(path_)) {}
PcapStream::~PcapStream() = default;

std::optional<StreamPacket> PcapStream::next() {
  auto rec = reader_->next();
  if (!rec) return std::nullopt;
  // The second port's packets: Velodyne position packets (8308), Ouster IMU packets (48 bytes, no
  // lidar packet of any model is that small).
  const bool second = rec->packet.dst_port == velodyne::kPositionPort || rec->packet.data.size() == ouster::kImuPacketSize;
  return StreamPacket{rec->packet.rx_ns, rec->packet.data, second, -1, -1.0};
}

bool PcapStream::rewind() {
  try {
    reader_ = std::make_unique<PcapReader>(path_);
    return true;
  } catch (const std::exception&) {
    return false;  // the file vanished or changed under us: end the replay
  }
}

std::string PcapStream::error() const { return reader_->error(); }

std::optional<StreamPacket> SyntheticStream::next() {
  const SyntheticPacket p = sensor_->next();
  return StreamPacket{p.time_ns, p.bytes, p.position, -1, p.truth.data ? p.truth.rotor_deg : -1.0};
}

ReplayStats run_replay(PacketStream& stream, UdpSender& sender, const ReplayOptions& o) {
  ReplayStats st;
  FaultInjector faults(o.faults);
  ScheduledFaults scheduled(o.scheduled, o.faults.seed);
  ReplayObserver* const obs = o.observer;
  const std::size_t batch = std::max<std::size_t>(1, o.batch);
  std::vector<std::vector<std::byte>> bufs(batch);
  for (auto& b : bufs) b.reserve(velodyne::kDataPacketSize);
  std::vector<OutDatagram> pending;
  std::vector<std::int64_t> pending_tags;
  pending.reserve(batch);
  pending_tags.reserve(batch);
  const double rate = o.rate > 0 ? o.rate : 1.0;
  const bool send_position = o.send_position && sender.destinations() > 1;
  // A second sensor's packets come from another address when we can send from one (loopback).
  const std::uint32_t foreign_source =
      (sender.destination_addr(0) >> 24) == 127 ? kForeignLoopbackSource : 0U;

  const Nanos t_begin = monotonic_now_ns();
  const Nanos start = o.start_monotonic_ns > 0 ? o.start_monotonic_ns : t_begin + o.lead_ns;
  const Nanos t_end = o.duration_ns > 0 ? t_begin + o.duration_ns : 0;

  auto flush = [&] {
    if (pending.empty()) return;
    const Nanos tx = obs != nullptr ? vehicle_now_ns() : 0;
    const SendResult r = sender.send_batch(pending);
    if (obs != nullptr) {
      for (const std::int64_t tag : pending_tags)
        if (tag >= 0) obs->sent(tag, tx);
      obs->batch_sent();
    }
    pending_tags.clear();
    st.sent += r.sent;
    st.send_errors += pending.size() - r.sent;
    ++st.batches;
    pending.clear();
  };
  bool stop = false;
  auto emit = [&](const NetPacket& fp) {
    const Nanos deadline = start + fp.offset_ns;
    bool on_time = false;
    if (deadline > monotonic_now_ns() + kSpinNs) {
      flush();
      if (t_end > 0 && deadline >= t_end) {
        if (!sleep_until(t_end)) st.stopped = true;
        stop = true;
        return;
      }
      if (!sleep_until(deadline)) {
        st.stopped = stop = true;
        return;
      }
      on_time = true;
    }
    const Nanos late = monotonic_now_ns() - deadline;
    if (late > kLateNs) ++st.late;
    st.max_late_ns = std::max(st.max_late_ns, late);
    std::vector<std::byte>& buf = bufs[pending.size()];
    buf.assign(fp.bytes.begin(), fp.bytes.end());
    pending.push_back(OutDatagram{buf, fp.position ? std::size_t{1} : std::size_t{0},
                                  fp.tag == kForeignTag ? foreign_source : 0U});
    pending_tags.push_back(fp.tag);
    (fp.position ? st.sent_position : st.sent_data) += 1;
    if (on_time || pending.size() == batch) flush();
  };

  Nanos first_t = 0, prev_t = 0;
  bool have_first = false;
  Nanos pass_base = 0, last_offset = 0;
  std::uint64_t pass_packets = 0;
  while (!stop) {
    if (shutdown_requested()) {
      st.stopped = true;
      break;
    }
    if (o.max_packets > 0 && st.read >= o.max_packets) break;
    if (t_end > 0 && monotonic_now_ns() >= t_end) break;
    const std::optional<StreamPacket> p = stream.next();
    if (!p) {
      st.stream_error = stream.error();
      if (!o.loop || pass_packets == 0 || !st.stream_error.empty() || !stream.rewind()) break;
      // Next pass starts one mean packet gap after the last packet of this one.
      const Nanos span = prev_t - first_t;
      const Nanos gap = pass_packets > 1 ? static_cast<Nanos>(static_cast<double>(span) / rate /
                                                             static_cast<double>(pass_packets - 1))
                                         : 1'000'000;
      pass_base = last_offset + gap;
      have_first = false;
      pass_packets = 0;
      ++st.loops;
      continue;
    }
    ++st.read;
    ++pass_packets;
    if (!have_first) {
      first_t = p->time_ns;
      have_first = true;
    }
    prev_t = p->time_ns;
    // Records out of time order in a capture are sent right away, never earlier than the last.
    const Nanos offset =
        std::max(last_offset, pass_base + static_cast<Nanos>(static_cast<double>(p->time_ns - first_t) / rate));
    last_offset = offset;
    if (p->position && !send_position) {
      ++st.skipped_position;
      continue;
    }
    const FaultStats before = faults.stats();
    const auto out = faults.push(offset, p->bytes, p->position, p->tag);
    if (obs != nullptr && p->tag >= 0) report_rate_fates(*obs, p->tag, before, faults.stats());
    for (const FaultedPacket& fp : out) {
      const bool own = fp.tag == p->tag;  // the rotor angle is this packet's (not a released one's)
      for (const NetPacket& np : scheduled.push({fp.offset_ns, fp.bytes, fp.position, fp.tag}, own ? p->rotor_deg : -1.0)) {
        report_decisions(obs, scheduled);
        emit(np);
        if (stop) break;
      }
      report_decisions(obs, scheduled);
      if (stop) break;
    }
  }
  if (!st.stopped) {
    for (const FaultedPacket& fp : faults.flush()) {
      for (const NetPacket& np : scheduled.push({fp.offset_ns, fp.bytes, fp.position, fp.tag})) emit(np);
      report_decisions(obs, scheduled);
    }
    for (const NetPacket& np : scheduled.flush()) emit(np);
  }
  flush();
  st.faults = faults.stats();
  st.elapsed_ns = monotonic_now_ns() - t_begin;
  return st;
}

std::string summary_line(const ReplayStats& s) {
  const double secs = static_cast<double>(s.elapsed_ns) * 1e-9;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "replay: sent %llu datagrams (data %llu, position %llu) in %.2f s, %.0f pkt/s, %llu batches, "
                "%llu late (max %.2f ms), %llu loops, %llu send errors, %llu position skipped; faults: dropped "
                "%llu, corrupted %llu, truncated %llu, duplicated %llu, reordered %llu, stalls %llu",
                static_cast<unsigned long long>(s.sent), static_cast<unsigned long long>(s.sent_data),
                static_cast<unsigned long long>(s.sent_position), secs,
                secs > 0 ? static_cast<double>(s.sent) / secs : 0.0, static_cast<unsigned long long>(s.batches),
                static_cast<unsigned long long>(s.late), static_cast<double>(s.max_late_ns) * 1e-6,
                static_cast<unsigned long long>(s.loops), static_cast<unsigned long long>(s.send_errors),
                static_cast<unsigned long long>(s.skipped_position),
                static_cast<unsigned long long>(s.faults.dropped), static_cast<unsigned long long>(s.faults.corrupted),
                static_cast<unsigned long long>(s.faults.truncated),
                static_cast<unsigned long long>(s.faults.duplicated),
                static_cast<unsigned long long>(s.faults.reordered), static_cast<unsigned long long>(s.faults.stalls));
  return buf;
}

}  // namespace sensor_rig::lidar::mock
