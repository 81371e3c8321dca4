#pragma once
// Reads UDP payloads from a pcap/pcapng file through libpcap, in file order, with the record time.
// Opening a missing/corrupt file throws PcapError; a truncated or corrupt record ends the
// iteration with error() set (never a crash). Non-UDP and fragmented frames are counted, skipped.
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/packet.hpp"
#include "sensor_rig/lidar/udp_frame.hpp"

namespace sensor_rig::lidar {

struct PcapError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct PcapStats {
  std::uint64_t records = 0;    // records read
  std::uint64_t udp = 0;        // UDP payloads returned
  std::uint64_t not_udp = 0;    // non-IPv4 or non-UDP frames
  std::uint64_t fragments = 0;  // IPv4 fragments (ignored)
  std::uint64_t truncated = 0;  // records cut short by the snap length
  std::uint64_t bad = 0;        // inconsistent headers
};

struct PcapRecord {
  PacketView packet;        // payload, rx_ns = record time (ns since epoch), dst_port
  std::uint16_t src_port = 0;
  std::uint32_t src_ip = 0;
  std::uint32_t dst_ip = 0;
};

class PcapReader {
 public:
  explicit PcapReader(const std::string& path);
  ~PcapReader();
  PcapReader(PcapReader&&) noexcept;
  PcapReader& operator=(PcapReader&&) noexcept;

  // The next UDP payload; nullopt at the end of the file or after a read error (see error()).
  // The payload stays valid until the next call.
  std::optional<PcapRecord> next();
  [[nodiscard]] const std::string& error() const noexcept;  // empty after a clean end
  [[nodiscard]] const PcapStats& stats() const noexcept;
  [[nodiscard]] int linktype() const noexcept;
  [[nodiscard]] const std::string& path() const noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sensor_rig::lidar
