#pragma once
// Records a LIDAR's raw UDP packets as received into rotating pcap files (`record:` per LIDAR):
// nanosecond pcap (magic 0xa1b23c4d, LINKTYPE_ETHERNET) with the kernel receive time as record
// time, so Wireshark, tcpdump, libpcap, `rig lidar decode` and `rig lidar replay` read the files as
// captures. The IPv4/UDP headers are the datagram's own where the source saw them (packet ring);
// from a UDP socket (whose kernel strips them) they are rebuilt from the datagram's source and
// destination addresses. The Ethernet header is a placeholder (locally administered MACs): neither
// source keeps the link header.
//
// Files `<dir>/<prefix>_<seq>_<UTC start>.pcap`; a new file when the next record would pass
// max_file_bytes or when a packet's time is max_file_ns after the file's first; at most max_files
// files with this prefix are kept (the oldest, by sequence, is deleted; files left by an earlier
// run with the same prefix count too). Never throws after construction, never blocks the caller
// beyond its write syscall: an error (directory missing or unwritable, disk full, EIO) closes the
// file at its last whole record (a short write is truncated away, so every file stays readable),
// is counted and kept in last_error(), and packets are dropped (counted) until a retry one
// retry_ns of packet time later opens a new file.
#include <cstddef>
#include <cstdint>
#include <deque>
#include <span>
#include <string>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/unique_fd.hpp"

namespace sensor_rig::lidar {

struct PcapRecorderConfig {
  std::string directory;                    // created when missing
  std::string prefix = "lidar";             // file name prefix (the LIDAR's name)
  std::uint64_t max_file_bytes = 256ULL << 20;
  Nanos max_file_ns = 60'000'000'000;       // 0 = no time rotation
  std::size_t max_files = 10;               // kept files with this prefix (>= 1)
  Nanos retry_ns = 1'000'000'000;           // after an error, packets are dropped this long
};

// Addresses of one datagram (IPv4, host byte order), for the rebuilt headers.
struct UdpAddressing {
  std::uint32_t src_ip = 0;
  std::uint16_t src_port = 0;
  std::uint32_t dst_ip = 0;
  std::uint16_t dst_port = 0;
};

// What a record keeps of a datagram beside its payload: the IPv4 + UDP headers as captured, or
// when there are none, the addresses to rebuild them from.
struct DatagramHeaders {
  UdpAddressing addressing;             // used when `captured` is empty
  std::span<const std::byte> captured;  // IPv4 header (options included) + UDP header
};

struct PcapRecorderStats {
  std::uint64_t packets = 0;          // records written
  std::uint64_t bytes = 0;            // file bytes written (headers included)
  std::uint64_t dropped = 0;          // packets not written (error, back-off, oversized)
  std::uint64_t errors = 0;           // open / write / truncate failures
  std::uint64_t files_opened = 0;
  std::uint64_t files_deleted = 0;    // rotated out by max_files
};

// Pure: the 24-byte file header and the 16 + 42-byte record / frame headers.
inline constexpr std::size_t kPcapFileHeaderSize = 24;
inline constexpr std::size_t kPcapRecordHeaderSize = 16;
inline constexpr std::size_t kUdpFrameHeaderSize = 14 + 20 + 8;  // Ethernet II, IPv4 (no options), UDP
inline constexpr std::size_t kMaxCapturedHeaders = 60 + 8;  // IPv4 with options, UDP
inline constexpr std::size_t kMaxRecordHead = kPcapRecordHeaderSize + 14 + kMaxCapturedHeaders;
inline constexpr std::size_t kMaxRecordedPayload = 65535 - 20 - 8;
void encode_pcap_file_header(std::span<std::byte, kPcapFileHeaderSize> out) noexcept;
// Record header (ts as s + ns) followed by the frame header of a `payload_size`-byte datagram.
void encode_pcap_record(Nanos ts_ns, const UdpAddressing& a, std::size_t payload_size,
                        std::span<std::byte, kPcapRecordHeaderSize + kUdpFrameHeaderSize> out) noexcept;
// The same with the datagram's captured IPv4 + UDP headers (at most kMaxCapturedHeaders bytes,
// else 0 is returned) copied as they are; returns the bytes written to `out`. When the payload was
// cut short (fewer bytes than the headers' total length say) the record's original length is the
// headers' and its captured length what there is, as a snap length would.
std::size_t encode_pcap_captured_record(Nanos ts_ns, std::span<const std::byte> captured, std::size_t payload_size,
                                        std::span<std::byte, kMaxRecordHead> out) noexcept;

// A sink's counters and state, copied for another thread to read.
struct RecordSinkStatus {
  PcapRecorderStats stats;
  std::string last_error;
  std::string current_file;
};

// Where a recording's writer thread puts records (recorder_thread.hpp): the pcap recorder, or a
// test's stand-in (a slow or blocked disk).
class RecordSink {
 public:
  RecordSink() = default;
  virtual ~RecordSink() = default;
  RecordSink(const RecordSink&) = delete;
  RecordSink& operator=(const RecordSink&) = delete;
  virtual bool write(std::span<const std::byte> payload, Nanos rx_ns, const DatagramHeaders& h) noexcept = 0;
  virtual void close() noexcept = 0;
  [[nodiscard]] virtual RecordSinkStatus status() const = 0;
};

class PcapRecorder final : public RecordSink {
 public:
  // Throws std::invalid_argument for an empty directory, max_files 0 or max_file_bytes too small
  // for one record; nothing touches the disk before the first packet.
  explicit PcapRecorder(PcapRecorderConfig cfg);
  ~PcapRecorder() override;
  PcapRecorder(const PcapRecorder&) = delete;
  PcapRecorder& operator=(const PcapRecorder&) = delete;

  // Appends one datagram received at rx_ns. False when it was not written (counted).
  bool write(std::span<const std::byte> payload, Nanos rx_ns, const DatagramHeaders& h) noexcept override;
  bool write(std::span<const std::byte> payload, Nanos rx_ns, const UdpAddressing& a) noexcept {
    return write(payload, rx_ns, DatagramHeaders{a, {}});
  }
  void close() noexcept override;  // ends the current file (the next write opens a new one)
  [[nodiscard]] RecordSinkStatus status() const override { return {stats_, last_error_, path_}; }

  [[nodiscard]] const PcapRecorderStats& stats() const noexcept { return stats_; }
  [[nodiscard]] const std::string& last_error() const noexcept { return last_error_; }
  [[nodiscard]] const std::string& current_file() const noexcept { return path_; }
  [[nodiscard]] const PcapRecorderConfig& config() const noexcept { return cfg_; }

 private:
  bool open_next(Nanos rx_ns) noexcept;
  void fail(const std::string& what, int err, Nanos rx_ns) noexcept;
  void scan_existing() noexcept;

  PcapRecorderConfig cfg_;
  PcapRecorderStats stats_;
  UniqueFd fd_;
  std::string path_;
  std::string last_error_;
  std::uint64_t file_bytes_ = 0;
  Nanos file_start_ns_ = 0;
  Nanos retry_at_ns_ = 0;
  bool in_backoff_ = false;
  bool scanned_ = false;
  std::uint64_t seq_ = 0;
  std::deque<std::string> files_;  // kept files, oldest first
};

}  // namespace sensor_rig::lidar
