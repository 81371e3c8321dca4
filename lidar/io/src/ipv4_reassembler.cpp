#include "sensor_rig/lidar/ipv4_reassembler.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "sensor_rig/lidar/udp_frame.hpp"

namespace sensor_rig::lidar {
namespace {

constexpr std::size_t kOutHeader = 20;  // the header of a reassembled datagram (no options)
constexpr std::uint16_t kMoreFragments = 0x2000;
constexpr std::uint16_t kOffsetMask = 0x1fff;

std::uint16_t be16(std::span<const std::byte> b, std::size_t at) noexcept {
  return static_cast<std::uint16_t>((std::to_integer<unsigned>(b[at]) << 8) | std::to_integer<unsigned>(b[at + 1]));
}
std::uint32_t be32(std::span<const std::byte> b, std::size_t at) noexcept {
  return (static_cast<std::uint32_t>(be16(b, at)) << 16) | be16(b, at + 2);
}
void put16(std::byte* p, std::uint16_t v) noexcept {
  p[0] = static_cast<std::byte>(v >> 8);
  p[1] = static_cast<std::byte>(v & 0xff);
}
void put32(std::byte* p, std::uint32_t v) noexcept {
  put16(p, static_cast<std::uint16_t>(v >> 16));
  put16(p + 2, static_cast<std::uint16_t>(v & 0xffff));
}

}  // namespace

const char* to_string(ReassemblyDrop d) noexcept {
  switch (d) {
    case ReassemblyDrop::kTimeout: return "timeout";
    case ReassemblyDrop::kOverlap: return "overlap";
    case ReassemblyDrop::kTooMany: return "too_many";
    case ReassemblyDrop::kOversize: return "oversize";
    case ReassemblyDrop::kMalformed: return "malformed";
    case ReassemblyDrop::kCount: break;
  }
  return "unknown";
}

std::uint64_t ReassemblyCounters::dropped_total() const noexcept {
  std::uint64_t n = 0;
  for (auto v : dropped) n += v;
  return n;
}

bool parse_ipv4_header(std::span<const std::byte> p, Ipv4Header& h) noexcept {
  if (p.size() < 20) return false;
  const unsigned v_ihl = std::to_integer<unsigned>(p[0]);
  if ((v_ihl >> 4) != 4) return false;
  h.header_bytes = static_cast<std::uint16_t>((v_ihl & 0x0f) * 4);
  h.total_bytes = be16(p, 2);
  if (h.header_bytes < 20 || h.total_bytes < h.header_bytes || h.total_bytes > p.size()) return false;
  h.id = be16(p, 4);
  const std::uint16_t frag = be16(p, 6);
  h.more_fragments = (frag & kMoreFragments) != 0;
  h.offset_bytes = static_cast<std::uint32_t>(frag & kOffsetMask) * 8;
  h.proto = std::to_integer<std::uint8_t>(p[9]);
  h.src = be32(p, 12);
  h.dst = be32(p, 16);
  return true;
}

Ipv4Reassembler::Ipv4Reassembler(const Ipv4ReassemblerConfig& config) : config_(config) {
  if (config.max_in_flight == 0 || config.max_in_flight > 1024)
    throw std::invalid_argument("ipv4 reassembler: max_in_flight must be in 1..1024");
  if (config.max_datagram_bytes < 68 || config.max_datagram_bytes > 65535)
    throw std::invalid_argument("ipv4 reassembler: max_datagram_bytes must be in 68..65535");
  if (config.timeout_ns <= 0) throw std::invalid_argument("ipv4 reassembler: timeout must be > 0");
  if (config.max_fragments == 0) throw std::invalid_argument("ipv4 reassembler: max_fragments must be > 0");
  if (config.remember_completed > 65536) throw std::invalid_argument("ipv4 reassembler: remember_completed must be <= 65536");
  entries_.resize(config.max_in_flight);
  completed_.resize(config.remember_completed);
  for (auto& e : entries_) {  // all storage now: push() never allocates
    e.buffer.resize(config.max_datagram_bytes);
    e.ranges.reserve(config.max_fragments);
  }
}

std::size_t Ipv4Reassembler::in_flight() const noexcept {
  return static_cast<std::size_t>(std::count_if(entries_.begin(), entries_.end(), [](const Entry& e) { return e.state == State::kOpen; }));
}

Ipv4Reassembler::Entry* Ipv4Reassembler::find(const Ipv4Header& h) noexcept {
  for (auto& e : entries_)
    if (e.state != State::kFree && e.id == h.id && e.src == h.src && e.dst == h.dst && e.proto == h.proto) return &e;
  return nullptr;
}

bool Ipv4Reassembler::completed_recently(const Ipv4Header& h, std::uint32_t end, Nanos age_ns) const noexcept {
  for (const auto& c : completed_) {
    if (c.at_ns >= 0 && c.id == h.id && c.src == h.src && c.dst == h.dst && c.proto == h.proto &&
        age_ns - c.at_ns < config_.timeout_ns && end <= c.total_payload)
      return true;
  }
  return false;
}

Ipv4Reassembler::Entry* Ipv4Reassembler::open(const Ipv4Header& h, Nanos rx_ns) noexcept {
  // A free slot, else a dead one (already counted), else the oldest open datagram: the one least
  // likely to complete.
  Entry* slot = nullptr;
  for (const State want : {State::kFree, State::kDead}) {
    for (auto& e : entries_) {
      if (e.state == want && (slot == nullptr || e.first_rx_ns < slot->first_rx_ns)) slot = &e;
    }
    if (slot != nullptr) break;
  }
  if (slot == nullptr) {
    slot = &*std::min_element(entries_.begin(), entries_.end(),
                              [](const Entry& a, const Entry& b) { return a.first_rx_ns < b.first_rx_ns; });
    drop(*slot, ReassemblyDrop::kTooMany);
  }
  slot->state = State::kOpen;
  slot->src = h.src;
  slot->dst = h.dst;
  slot->id = h.id;
  slot->proto = h.proto;
  slot->first_rx_ns = rx_ns;
  slot->total_payload = 0;
  slot->ranges.clear();
  return slot;
}

void Ipv4Reassembler::drop(Entry& e, ReassemblyDrop why) noexcept {
  e.state = State::kDead;
  ++counters_.dropped[static_cast<std::size_t>(why)];
}

bool Ipv4Reassembler::complete(const Entry& e) const noexcept {
  if (e.total_payload == 0) return false;
  std::uint64_t have = 0;
  for (const auto& r : e.ranges) have += r.end - r.begin;  // disjoint, within total: sum == total iff covered
  return have == e.total_payload;
}

ReassemblyResult Ipv4Reassembler::push(std::span<const std::byte> packet, Nanos rx_ns, Nanos age_ns) noexcept {
  Ipv4Header h;
  if (!parse_ipv4_header(packet, h)) {
    ++counters_.dropped[static_cast<std::size_t>(ReassemblyDrop::kMalformed)];
    return {ReassemblyStatus::kDropped, {}, 0};
  }
  if (!h.is_fragment()) return {ReassemblyStatus::kNotFragment, packet.first(h.total_bytes), rx_ns};
  ++counters_.fragments;
  const std::uint32_t len = static_cast<std::uint32_t>(h.total_bytes - h.header_bytes);
  const Range r{h.offset_bytes, h.offset_bytes + len};
  Entry* e = find(h);
  if (e != nullptr && e->state == State::kDead) return {ReassemblyStatus::kDropped, {}, 0};  // counted already
  if (e == nullptr && !completed_.empty() && completed_recently(h, r.end, age_ns)) {
    ++counters_.duplicates;  // a copy of a fragment of a datagram already delivered
    return {ReassemblyStatus::kIncomplete, {}, 0};
  }
  // A fragment with no data, or a non-last one whose length is not a multiple of 8 (RFC 791).
  const bool malformed = len == 0 || (h.more_fragments && len % 8 != 0);
  if (r.end + kOutHeader > config_.max_datagram_bytes || malformed) {
    // Kept as a dead entry, so the datagram's other fragments are not counted again.
    if (e == nullptr) e = open(h, age_ns);
    drop(*e, malformed ? ReassemblyDrop::kMalformed : ReassemblyDrop::kOversize);
    return {ReassemblyStatus::kDropped, {}, 0};
  }
  if (e == nullptr) e = open(h, age_ns);
  if (!h.more_fragments) {  // the last fragment fixes the size; a second, different one contradicts it
    if (e->total_payload != 0 && e->total_payload != r.end) {
      drop(*e, ReassemblyDrop::kMalformed);
      return {ReassemblyStatus::kDropped, {}, 0};
    }
    e->total_payload = r.end;
  }
  for (const auto& have : e->ranges) {
    if (have.begin == r.begin && have.end == r.end) {  // a retransmitted / duplicated copy
      ++counters_.duplicates;
      return {ReassemblyStatus::kIncomplete, {}, 0};
    }
    if (r.begin < have.end && have.begin < r.end) {
      drop(*e, ReassemblyDrop::kOverlap);
      return {ReassemblyStatus::kDropped, {}, 0};
    }
  }
  if ((e->total_payload != 0 && r.end > e->total_payload) || e->ranges.size() >= config_.max_fragments) {
    // Data past the last fragment's end is malformed; a datagram cut in too many pieces is oversize.
    drop(*e, e->ranges.size() >= config_.max_fragments ? ReassemblyDrop::kOversize : ReassemblyDrop::kMalformed);
    return {ReassemblyStatus::kDropped, {}, 0};
  }
  for (const auto& have : e->ranges) {
    if (e->total_payload != 0 && have.end > e->total_payload) {
      drop(*e, ReassemblyDrop::kMalformed);
      return {ReassemblyStatus::kDropped, {}, 0};
    }
  }
  std::memcpy(e->buffer.data() + kOutHeader + r.begin, packet.data() + h.header_bytes, len);
  e->ranges.push_back(r);
  if (r.begin == 0) {  // the first fragment's header (options dropped) becomes the datagram's
    std::memcpy(e->buffer.data(), packet.data(), kOutHeader);
  }
  if (!complete(*e)) return {ReassemblyStatus::kIncomplete, {}, 0};
  std::byte* hdr = e->buffer.data();
  const auto total = static_cast<std::uint16_t>(kOutHeader + e->total_payload);
  hdr[0] = std::byte{0x45};
  put16(hdr + 2, total);
  put16(hdr + 4, e->id);
  put16(hdr + 6, 0);  // no fragment bits
  hdr[9] = static_cast<std::byte>(e->proto);
  put16(hdr + 10, 0);
  put32(hdr + 12, e->src);
  put32(hdr + 16, e->dst);
  put16(hdr + 10, ipv4_header_checksum({hdr, kOutHeader}));  // a recording keeps this header
  e->state = State::kFree;
  if (!completed_.empty()) {
    completed_[completed_next_] = Completed{e->src, e->dst, e->id, e->proto, e->total_payload, age_ns};
    completed_next_ = (completed_next_ + 1) % completed_.size();
  }
  ++counters_.reassembled;
  return {ReassemblyStatus::kComplete, std::span<const std::byte>(e->buffer.data(), total), rx_ns};
}

std::size_t Ipv4Reassembler::expire(Nanos now) noexcept {
  std::size_t n = 0;
  for (auto& e : entries_) {
    if (e.state == State::kFree || now - e.first_rx_ns < config_.timeout_ns) continue;
    if (e.state == State::kOpen) {
      drop(e, ReassemblyDrop::kTimeout);
      ++n;
    }
    e.state = State::kFree;
  }
  return n;
}

}  // namespace sensor_rig::lidar
