// The mock LIDAR's truth record (see truth_stream.hpp).
#include "sensor_rig/lidar/mock/truth_stream.hpp"

#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <set>

namespace sensor_rig::lidar::mock {
namespace {

// Parts in flight at once: a sendmmsg batch, a reordered or duplicated packet's wait; a part still
// pending when its slot comes round again is written as never sent.
constexpr std::size_t kRing = 8192;

// Which fate wins when several faults touch one packet: the one that changes most what arrives.
int severity(truth::Fate f) noexcept {
  using truth::Fate;
  switch (f) {
    case Fate::kSent: return 0;
    case Fate::kDuplicated: return 1;
    case Fate::kDelayed: return 2;
    case Fate::kCorrupted: return 3;
    case Fate::kTruncated: return 4;
    case Fate::kDropped: return 5;
    case Fate::kNotSent: return 6;
  }
  return 0;
}

// The fault ids whose lines a truth record already holds (an earlier run of a restarted mock wrote
// them). A chunked scan for line starts `{"f":`: a ten-minute record of a VLP-32C is ~100 MB.
std::set<std::uint64_t> recorded_fault_ids(const std::string& path) {
  // Beside the sender, not before it: ~65 ms for 100 MB here, the restarted run's first packets
  // would leave that late. And at normal priority: the mock's SCHED_FIFO is for its sends.
  sched_param normal{};
  (void)pthread_setschedparam(pthread_self(), SCHED_OTHER, &normal);
  std::set<std::uint64_t> ids;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) return ids;
  static constexpr char kNeedle[] = "\n{\"f\":";
  constexpr std::size_t kNeedleLen = sizeof kNeedle - 1;
  constexpr std::size_t kChunk = 1 << 20, kKeep = 32;  // kKeep: a needle and its id across a chunk's end
  std::vector<char> buf(kChunk + kKeep + 1);
  std::size_t have = 0;
  while (true) {
    const std::size_t n = std::fread(buf.data() + have, 1, kChunk, f);
    have += n;
    buf[have] = '\0';
    const bool last = n == 0;
    const char* end = buf.data() + have;
    const char* p = buf.data();
    while (true) {
      const char* hit = static_cast<const char*>(::memmem(p, static_cast<std::size_t>(end - p), kNeedle, kNeedleLen));
      if (hit == nullptr || (!last && end - hit < static_cast<std::ptrdiff_t>(kKeep))) {
        p = hit != nullptr ? hit : std::max(p, end - static_cast<std::ptrdiff_t>(kNeedleLen - 1));
        break;
      }
      ids.insert(std::strtoull(hit + kNeedleLen, nullptr, 10));
      p = hit + kNeedleLen;
    }
    if (last) break;
    have = static_cast<std::size_t>(end - p);  // the unsearched tail goes first in the next chunk
    std::memmove(buf.data(), p, have);
  }
  std::fclose(f);
  return ids;
}

}  // namespace

TruthStream::TruthStream(std::unique_ptr<FaultySensor> sensor, std::unique_ptr<truth::Writer> writer,
                         std::vector<FaultNote> faults)
    : sensor_(std::move(sensor)), writer_(std::move(writer)), faults_(std::move(faults)), noted_(faults_.size(), false),
      ring_(kRing) {
  read_earlier_runs();
}

TruthStream::TruthStream(std::unique_ptr<PacketStream> capture, std::unique_ptr<truth::Writer> writer,
                         std::vector<FaultNote> faults)
    : capture_(std::move(capture)), writer_(std::move(writer)), faults_(std::move(faults)), noted_(faults_.size(), false),
      ring_(kRing) {
  read_earlier_runs();
}

TruthStream::~TruthStream() { finish(); }

TruthStream::Pending* TruthStream::pending(std::int64_t tag) noexcept {
  if (tag < 0) return nullptr;
  Pending& p = ring_[static_cast<std::size_t>(tag) % kRing];
  return p.live && p.r.seq == static_cast<std::uint64_t>(tag) ? &p : nullptr;
}

void TruthStream::put(Pending& p) {
  if (writer_) writer_->part(p.r);
  p.live = false;
}

void TruthStream::note_fault(std::uint64_t id, std::int64_t unit) {
  for (std::size_t i = 0; i < faults_.size(); ++i) {
    if (faults_[i].id != id) continue;
    if (faults_[i].before_start) settle_earlier_runs(true);  // a resumed fault: is its line an earlier run's?
    if (noted_[i]) continue;
    noted_[i] = true;
    if (!writer_) continue;
    writer_->fault({id, faults_[i].kind, faults_[i].at_ns, faults_[i].until_ns, unit, faults_[i].detail});
    writer_->flush();  // a few a minute: on disk before a kill (the next run's read_earlier_runs reads it)
  }
}

void TruthStream::read_earlier_runs() {
  if (!writer_ || std::none_of(faults_.begin(), faults_.end(), [](const FaultNote& f) { return f.before_start; })) return;
  // Our header is the record's last line so far, and this run writes no line of a before_start
  // fault until the scan is in (settle_earlier_runs): every such line it finds is an earlier run's.
  earlier_ = std::async(std::launch::async, recorded_fault_ids, writer_->path());
}

void TruthStream::settle_earlier_runs(bool wait) {
  if (!earlier_.valid() || (!wait && earlier_.wait_for(std::chrono::seconds(0)) != std::future_status::ready)) return;
  const std::set<std::uint64_t> earlier = earlier_.get();
  for (std::size_t i = 0; i < faults_.size(); ++i) {
    const FaultNote& f = faults_[i];
    if (!f.before_start) continue;
    if (earlier.contains(f.id)) {
      noted_[i] = true;  // the run alive at its time injected it (its line and parts say how)
    } else if (!f.resumed) {
      noted_[i] = true;
      writer_->fault({f.id, f.kind, f.at_ns, f.until_ns, -1,
                      std::string(truth::kNotInjected) +
                          "its time came before this run of the mock began and no earlier run acted on it "
                          "(the mock was not running, or was killed first)" + (f.detail.empty() ? std::string() : "; " + f.detail)});
    }
  }
  writer_->flush();
}

void TruthStream::write_units() {
  for (const FaultySensor::Began& b : sensor_->began()) note_fault(b.id, b.unit);
  sensor_->began().clear();
  auto& closed = sensor_->units().closed();
  if (writer_)
    for (const ClosedUnit& u : closed) writer_->unit({u.unit, u.acq_ns, u.dev_ns, u.parts});
  closed.clear();
}

std::optional<StreamPacket> TruthStream::next() {
  settle_earlier_runs(false);
  if (capture_) {
    auto p = capture_->next();
    if (!p || p->position) return p;
    Pending& slot = ring_[next_seq_ % kRing];
    if (slot.live) put(slot);
    slot.r = truth::PartRecord{next_seq_, -1, 0, 0, 0, truth::Fate::kSent, 0};
    slot.live = true;
    p->tag = static_cast<std::int64_t>(next_seq_++);
    return p;
  }
  while (true) {
    const FaultyPacket fp = sensor_->next();
    write_units();
    const SyntheticPacket& p = fp.packet;
    if (!fp.device && p.truth.data) return StreamPacket{p.time_ns, p.bytes, p.position, kForeignTag, -1.0};
    if (!fp.device || !p.truth.data) return StreamPacket{p.time_ns, p.bytes, p.position, -1, -1.0};
    Pending& slot = ring_[next_seq_ % kRing];
    if (slot.live) put(slot);
    slot.r = truth::PartRecord{next_seq_, fp.units.first, p.truth.acq_ns, p.truth.dev_ns, 0, fp.fate, fp.fault, fp.units.last};
    slot.live = true;
    const auto tag = static_cast<std::int64_t>(next_seq_++);
    if (fp.fate == truth::Fate::kNotSent) {  // the sensor did not produce it
      put(slot);
      continue;
    }
    return StreamPacket{p.time_ns, p.bytes, false, tag, p.truth.rotor_deg};
  }
}

bool TruthStream::rewind() { return capture_ ? capture_->rewind() : true; }

std::string TruthStream::error() const { return capture_ ? capture_->error() : std::string{}; }

void TruthStream::fate(std::int64_t tag, truth::Fate f, std::uint64_t fault) {
  Pending* p = pending(tag);
  if (p == nullptr) return;
  if (fault != 0) note_fault(fault, p->r.unit);
  if (severity(f) > severity(p->r.fate) || (p->r.fault == 0 && fault != 0 && f == p->r.fate)) {
    p->r.fate = f;
    p->r.fault = fault != 0 ? fault : p->r.fault;
  }
  if (f == truth::Fate::kDropped) put(*p);  // never on the wire: nothing more will happen to it
}

void TruthStream::sent(std::int64_t tag, Nanos tx_ns) {
  Pending* p = pending(tag);
  if (p == nullptr) return;
  p->r.tx_ns = tx_ns;
  put(*p);
}

void TruthStream::batch_sent() {
  if (writer_) writer_->flush();  // one write() per sendmmsg: ~0.7-1.8 k a second per mock
}

void TruthStream::finish() {
  if (finished_) return;
  finished_ = true;
  // In sequence order, as they were rendered.
  std::vector<Pending*> left;
  for (Pending& p : ring_)
    if (p.live) left.push_back(&p);
  std::sort(left.begin(), left.end(), [](const Pending* a, const Pending* b) { return a->r.seq < b->r.seq; });
  for (Pending* p : left) {
    // Never handed to the socket: the mock stopped before it was due (not a loss on the way).
    if (p->r.tx_ns == 0 && p->r.fate != truth::Fate::kDropped) p->r.fate = truth::Fate::kNotSent;
    put(*p);
  }
  if (sensor_) {
    sensor_->units().finish();
    write_units();
  }
  settle_earlier_runs(true);
  for (std::size_t i = 0; i < faults_.size(); ++i)
    if (!noted_[i]) note_fault(faults_[i].id, -1);
  if (writer_) writer_->flush();
}

}  // namespace sensor_rig::lidar::mock
