#include "sample_record.hpp"

#include <fcntl.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace sensor_rig::rig {
namespace {

constexpr std::string_view kHeader =
    "topic,seq,acquisition_ns,first_rx_ns,last_rx_ns,publish_ns,written_ns,received_ns,missing_packets,dropped,"
    "size_bytes,ecu_status_ns,packets";
constexpr std::size_t kFields = 13;
// Older recordings: before the `packets` column (12), and before the dbw `ecu` stage (11).
constexpr std::string_view kHeaderWithoutPackets = kHeader.substr(0, kHeader.rfind(','));
constexpr std::string_view kHeaderWithoutEcu = kHeaderWithoutPackets.substr(0, kHeaderWithoutPackets.rfind(','));

double ms_between(Nanos from, Nanos to) { return static_cast<double>(to - from) * 1e-6; }

void put_time(std::string& out, Nanos t) {
  out += ',';
  if (t != 0) out += std::to_string(t);
}

template <class T>
bool parse_number(std::string_view s, T& out) {
  if (s.empty()) {
    out = 0;
    return true;
  }
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && end == s.data() + s.size();
}

// Topic names are ROS names: no commas, quotes or newlines are expected; such a name is refused.
bool plain_field(std::string_view s) { return s.find_first_of(",\"\r\n") == std::string_view::npos; }

}  // namespace

std::array<std::optional<double>, kStageCount> stage_latencies_ms(const SampleRecord& r) {
  std::array<std::optional<double>, kStageCount> s;
  if (r.first_rx_ns > 0 && r.acquisition_ns > 0) s[kSensor] = ms_between(r.acquisition_ns, r.first_rx_ns);
  if (r.first_rx_ns > 0 && r.last_rx_ns > 0) s[kAssemble] = ms_between(r.first_rx_ns, r.last_rx_ns);
  if (r.last_rx_ns > 0 && r.publish_ns > 0) s[kProcess] = ms_between(r.last_rx_ns, r.publish_ns);
  if (r.written_ns > 0 && r.publish_ns > 0) s[kWrite] = ms_between(r.publish_ns, r.written_ns);
  if (r.received_ns > 0 && r.publish_ns > 0) s[kDds] = ms_between(r.publish_ns, r.received_ns);
  if (r.received_ns > 0 && r.acquisition_ns > 0) s[kTotal] = ms_between(r.acquisition_ns, r.received_ns);
  if (r.written_ns > 0 && r.last_rx_ns > 0) s[kToWire] = ms_between(r.last_rx_ns, r.written_ns);
  if (r.ecu_status_ns > 0 && r.written_ns > 0) s[kEcu] = ms_between(r.written_ns, r.ecu_status_ns);
  return s;
}

std::string_view record_csv_header() { return kHeader; }

std::string to_csv_line(const SampleRecord& r) {
  std::string out = plain_field(r.topic) ? r.topic : std::string("?");
  out += ',';
  out += std::to_string(r.seq);
  for (Nanos t : {r.acquisition_ns, r.first_rx_ns, r.last_rx_ns, r.publish_ns, r.written_ns, r.received_ns})
    put_time(out, t);
  for (std::uint32_t v : {r.missing_packets, r.dropped, r.size_bytes}) {
    out += ',';
    out += std::to_string(v);
  }
  put_time(out, r.ecu_status_ns);
  out += ',';
  out += std::to_string(r.packets);
  out += '\n';
  return out;
}

std::optional<SampleRecord> parse_csv_line(std::string_view line) { return parse_csv_line(line, kFields); }

std::optional<SampleRecord> parse_csv_line(std::string_view line, std::size_t fields) {
  if (fields < kFields - 2 || fields > kFields) return std::nullopt;
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  std::array<std::string_view, kFields> f;
  std::size_t n = 0;
  for (std::size_t start = 0;;) {
    const std::size_t comma = line.find(',', start);
    if (n == fields) return std::nullopt;
    f[n++] = line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  if (n != fields || f[0].empty() || f[1].empty()) return std::nullopt;
  SampleRecord r;
  r.topic = std::string(f[0]);
  bool ok = parse_number(f[1], r.seq);
  Nanos* times[] = {&r.acquisition_ns, &r.first_rx_ns, &r.last_rx_ns, &r.publish_ns, &r.written_ns, &r.received_ns};
  for (std::size_t i = 0; i < std::size(times); ++i) ok = ok && parse_number(f[2 + i], *times[i]);
  for (std::size_t i = 8; i < 11; ++i) ok = ok && !f[i].empty();  // counts are always written
  ok = ok && parse_number(f[8], r.missing_packets) && parse_number(f[9], r.dropped) && parse_number(f[10], r.size_bytes);
  if (fields >= kFields - 1) ok = ok && parse_number(f[11], r.ecu_status_ns);
  if (fields == kFields) ok = ok && parse_number(f[12], r.packets);
  if (!ok) return std::nullopt;
  return r;
}

RecordFile::RecordFile(const std::string& path)
    : fd_(::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644)), path_(path) {
  if (!fd_) throw std::runtime_error("cannot create " + path + ": " + std::strerror(errno));
  pending_ = std::string(kHeader) + "\n";
  flush();
  rows_ = 0;  // rows() counts records, not the header
}

void RecordFile::flush() {
  std::size_t done = 0;
  while (done < pending_.size()) {
    const ssize_t n = ::write(fd_.get(), pending_.data() + done, pending_.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw std::runtime_error("cannot write " + path_ + ": " + std::strerror(errno));
    done += static_cast<std::size_t>(n);
  }
  rows_ += static_cast<std::uint64_t>(std::count(pending_.begin(), pending_.end(), '\n'));
  pending_.clear();
}

std::vector<SampleRecord> read_records(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::string line;
  if (!std::getline(in, line)) line.clear();
  if (!line.empty() && line.back() == '\r') line.pop_back();
  const std::size_t fields = line == kHeader                ? kFields
                             : line == kHeaderWithoutPackets ? kFields - 1
                             : line == kHeaderWithoutEcu     ? kFields - 2
                                                             : 0;
  if (fields == 0)
    throw std::runtime_error(path + ":1: not a `rig monitor --record` file (header: " + std::string(kHeader) + ")");
  std::vector<SampleRecord> out;
  for (std::size_t no = 2; std::getline(in, line); ++no) {
    if (line.empty()) continue;
    auto r = parse_csv_line(line, fields);
    if (!r) throw std::runtime_error(path + ":" + std::to_string(no) + ": bad record line");
    out.push_back(std::move(*r));
  }
  return out;
}

}  // namespace sensor_rig::rig
