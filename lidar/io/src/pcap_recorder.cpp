// Rotating pcap recorder (see pcap_recorder.hpp).
#include "sensor_rig/lidar/pcap_recorder.hpp"

#include <fcntl.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <stdexcept>
#include <system_error>
#include <utility>
#include <vector>

#include "sensor_rig/lidar/udp_frame.hpp"

namespace sensor_rig::lidar {
namespace {

constexpr std::uint32_t kNanosecondMagic = 0xa1b23c4d;
constexpr std::uint32_t kLinktypeEthernet = 1;
constexpr std::uint32_t kSnapLen = 65535 + 14;

void put_le(std::byte* p, std::uint64_t v, int n) noexcept {
  for (int i = 0; i < n; ++i) p[i] = static_cast<std::byte>((v >> (8 * i)) & 0xFF);
}
void put_be(std::byte* p, std::uint64_t v, int n) noexcept {
  for (int i = 0; i < n; ++i) p[i] = static_cast<std::byte>((v >> (8 * (n - 1 - i))) & 0xFF);
}

// The record header (ts as s + ns, captured and original length) and the placeholder Ethernet
// header after it; returns where the IPv4 header goes.
std::byte* put_record_and_ethernet(std::byte* p, Nanos ts_ns, std::size_t caplen, std::size_t len) noexcept {
  const Nanos t = std::max<Nanos>(ts_ns, 0);
  put_le(p, static_cast<std::uint64_t>(t / 1'000'000'000), 4);
  put_le(p + 4, static_cast<std::uint64_t>(t % 1'000'000'000), 4);
  put_le(p + 8, caplen, 4);
  put_le(p + 12, len, 4);
  std::byte* e = p + kPcapRecordHeaderSize;
  // Ethernet II: locally administered MACs (neither source keeps the link header), type IPv4.
  const std::array<std::uint8_t, 6> dst_mac{0x02, 0, 0, 0, 0, 0x02}, src_mac{0x02, 0, 0, 0, 0, 0x01};
  std::memcpy(e, dst_mac.data(), 6);
  std::memcpy(e + 6, src_mac.data(), 6);
  put_be(e + 12, 0x0800, 2);
  return e + 14;
}

std::string utc_stamp(Nanos ns) {
  const std::time_t s = static_cast<std::time_t>(ns / 1'000'000'000);
  std::tm tm{};
  gmtime_r(&s, &tm);
  std::array<char, 32> b{};
  std::strftime(b.data(), b.size(), "%Y%m%dT%H%M%SZ", &tm);
  return b.data();
}

// "<prefix>_<seq>_..." -> seq, or -1.
long long seq_of(const std::string& name, const std::string& prefix) {
  if (name.size() < prefix.size() + 8 || name.compare(0, prefix.size() + 1, prefix + "_") != 0) return -1;
  if (name.size() < 5 || name.compare(name.size() - 5, 5, ".pcap") != 0) return -1;
  const std::size_t start = prefix.size() + 1;
  const std::size_t end = name.find('_', start);
  if (end == std::string::npos || end == start) return -1;
  long long v = 0;
  for (std::size_t i = start; i < end; ++i) {
    if (name[i] < '0' || name[i] > '9') return -1;
    v = v * 10 + (name[i] - '0');
  }
  return v;
}

}  // namespace

void encode_pcap_file_header(std::span<std::byte, kPcapFileHeaderSize> out) noexcept {
  std::byte* p = out.data();
  put_le(p, kNanosecondMagic, 4);
  put_le(p + 4, 2, 2);  // version 2.4
  put_le(p + 6, 4, 2);
  put_le(p + 8, 0, 4);  // thiszone
  put_le(p + 12, 0, 4);  // sigfigs
  put_le(p + 16, kSnapLen, 4);
  put_le(p + 20, kLinktypeEthernet, 4);
}

void encode_pcap_record(Nanos ts_ns, const UdpAddressing& a, std::size_t payload_size,
                        std::span<std::byte, kPcapRecordHeaderSize + kUdpFrameHeaderSize> out) noexcept {
  const std::size_t len = kUdpFrameHeaderSize + payload_size;
  std::memset(out.data(), 0, out.size());
  std::byte* ip = put_record_and_ethernet(out.data(), ts_ns, len, len);
  ip[0] = std::byte{0x45};
  put_be(ip + 2, 20 + 8 + payload_size, 2);
  put_be(ip + 6, 0x4000, 2);  // don't fragment: one datagram, reassembled by the kernel
  ip[8] = std::byte{64};
  ip[9] = std::byte{17};  // UDP
  put_be(ip + 12, a.src_ip, 4);
  put_be(ip + 16, a.dst_ip, 4);
  put_be(ip + 10, ipv4_header_checksum({ip, 20}), 2);
  std::byte* udp = ip + 20;
  put_be(udp, a.src_port, 2);
  put_be(udp + 2, a.dst_port, 2);
  put_be(udp + 4, std::min<std::size_t>(8 + payload_size, 65535), 2);
  // UDP checksum 0: "not computed" (allowed for IPv4).
}

std::size_t encode_pcap_captured_record(Nanos ts_ns, std::span<const std::byte> captured, std::size_t payload_size,
                                        std::span<std::byte, kMaxRecordHead> out) noexcept {
  if (captured.size() < 20 + 8 || captured.size() > kMaxCapturedHeaders) return 0;
  const std::size_t caplen = 14 + captured.size() + payload_size;
  const std::size_t ip_total =
      (std::to_integer<std::size_t>(captured[2]) << 8) | std::to_integer<std::size_t>(captured[3]);
  const std::size_t len = std::max(caplen, 14 + ip_total);
  std::byte* ip = put_record_and_ethernet(out.data(), ts_ns, caplen, len);
  std::memcpy(ip, captured.data(), captured.size());
  return kPcapRecordHeaderSize + 14 + captured.size();
}

PcapRecorder::PcapRecorder(PcapRecorderConfig cfg) : cfg_(std::move(cfg)) {
  if (cfg_.directory.empty()) throw std::invalid_argument("record: directory is empty");
  if (cfg_.max_files == 0) throw std::invalid_argument("record: max_files must be at least 1");
  if (cfg_.max_file_bytes < kPcapFileHeaderSize + kPcapRecordHeaderSize + kUdpFrameHeaderSize + 1500)
    throw std::invalid_argument("record: max_file_bytes " + std::to_string(cfg_.max_file_bytes) +
                                " cannot hold one packet");
  if (cfg_.max_file_ns < 0 || cfg_.retry_ns < 0) throw std::invalid_argument("record: negative time");
  if (cfg_.prefix.empty() || cfg_.prefix.find('/') != std::string::npos)
    throw std::invalid_argument("record: bad file prefix '" + cfg_.prefix + "'");
}

PcapRecorder::~PcapRecorder() { close(); }

void PcapRecorder::close() noexcept {
  fd_.reset();
  file_bytes_ = 0;
}

void PcapRecorder::fail(const std::string& what, int err, Nanos rx_ns) noexcept {
  ++stats_.errors;
  last_error_ = what + ": " + std::strerror(err);
  close();
  in_backoff_ = true;
  retry_at_ns_ = rx_ns + cfg_.retry_ns;
}

void PcapRecorder::scan_existing() noexcept {
  scanned_ = true;
  std::error_code ec;
  std::vector<std::pair<long long, std::string>> found;
  for (std::filesystem::directory_iterator it(cfg_.directory, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (const long long s = seq_of(name, cfg_.prefix); s >= 0) found.emplace_back(s, it->path().string());
  }
  std::sort(found.begin(), found.end());
  for (auto& [s, path] : found) {
    files_.push_back(std::move(path));
    seq_ = static_cast<std::uint64_t>(s) + 1;
  }
}

bool PcapRecorder::open_next(Nanos rx_ns) noexcept {
  std::error_code ec;
  std::filesystem::create_directories(cfg_.directory, ec);
  if (ec) {
    fail("record: cannot create " + cfg_.directory, ec.value(), rx_ns);
    return false;
  }
  if (!scanned_) scan_existing();
  std::array<char, 16> seq{};
  std::snprintf(seq.data(), seq.size(), "%06llu", static_cast<unsigned long long>(seq_));
  const std::string path = cfg_.directory + "/" + cfg_.prefix + "_" + seq.data() + "_" + utc_stamp(rx_ns) + ".pcap";
  UniqueFd fd(::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
  if (!fd) {
    fail("record: cannot open " + path, errno, rx_ns);
    return false;
  }
  ++seq_;
  std::array<std::byte, kPcapFileHeaderSize> h{};
  encode_pcap_file_header(h);
  if (::write(fd.get(), h.data(), h.size()) != static_cast<ssize_t>(h.size())) {
    const int err = errno == 0 ? ENOSPC : errno;
    ::unlink(path.c_str());
    fail("record: cannot write " + path, err, rx_ns);
    return false;
  }
  fd_ = std::move(fd);
  path_ = path;
  file_bytes_ = h.size();
  file_start_ns_ = rx_ns;
  stats_.bytes += h.size();
  ++stats_.files_opened;
  files_.push_back(path);
  while (files_.size() > cfg_.max_files) {
    if (::unlink(files_.front().c_str()) == 0) ++stats_.files_deleted;
    files_.pop_front();
  }
  in_backoff_ = false;
  return true;
}

bool PcapRecorder::write(std::span<const std::byte> payload, Nanos rx_ns, const DatagramHeaders& h) noexcept {
  if (payload.size() > kMaxRecordedPayload) {
    ++stats_.dropped;
    return false;
  }
  if (in_backoff_) {
    if (rx_ns < retry_at_ns_) {
      ++stats_.dropped;
      return false;
    }
  }
  std::array<std::byte, kMaxRecordHead> head{};
  std::size_t head_size = kPcapRecordHeaderSize + kUdpFrameHeaderSize;
  if (h.captured.empty()) {
    encode_pcap_record(rx_ns, h.addressing, payload.size(), std::span(head).first<kPcapRecordHeaderSize + kUdpFrameHeaderSize>());
  } else {
    head_size = encode_pcap_captured_record(rx_ns, h.captured, payload.size(), head);
  }
  const std::uint64_t record = head_size + payload.size();
  if (head_size == 0 || record - kPcapRecordHeaderSize > kSnapLen) {  // headers no IPv4 datagram has
    ++stats_.dropped;
    return false;
  }
  if (fd_ && (file_bytes_ + record > cfg_.max_file_bytes ||
              (cfg_.max_file_ns > 0 && rx_ns - file_start_ns_ >= cfg_.max_file_ns))) {
    close();
  }
  if (!fd_ && !open_next(rx_ns)) {
    ++stats_.dropped;
    return false;
  }
  std::array<iovec, 2> iov{iovec{head.data(), head_size},
                           iovec{const_cast<std::byte*>(payload.data()), payload.size()}};
  const ssize_t n = ::writev(fd_.get(), iov.data(), static_cast<int>(iov.size()));
  if (n != static_cast<ssize_t>(record)) {
    const int err = n < 0 ? errno : ENOSPC;  // a short write: the disk (or the file size limit) is full
    // Cut the partial record away: the file ends at its last whole record and stays readable.
    if (n > 0 && ::ftruncate(fd_.get(), static_cast<off_t>(file_bytes_)) != 0) ++stats_.errors;
    fail("record: write " + path_, err, rx_ns);
    ++stats_.dropped;
    return false;
  }
  file_bytes_ += record;
  stats_.bytes += record;
  ++stats_.packets;
  return true;
}

}  // namespace sensor_rig::lidar
