#pragma once
// Mock LIDAR sender: plays a packet stream (a capture's UDP payloads or a synthetic sensor) to UDP
// destinations at the stream's own timing, scaled by a rate factor, optionally looping, through
// the fault injector. Pacing sleeps on absolute CLOCK_MONOTONIC deadlines (clock_nanosleep) and
// sends everything already due in one sendmmsg batch when it falls behind.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/truth_record.hpp"
#include "sensor_rig/lidar/mock/fault_injector.hpp"
#include "sensor_rig/lidar/mock/scheduled_faults.hpp"
#include "sensor_rig/lidar/mock/synthetic_velodyne.hpp"
#include "sensor_rig/lidar/udp_sender.hpp"

namespace sensor_rig::lidar {
class PcapReader;
}

namespace sensor_rig::lidar::mock {

// StreamPacket::tag of a second sensor's packets: sent from another source address on loopback.
inline constexpr std::int64_t kForeignTag = -2;
// That address: 127.0.0.253 (any 127/8 address is local on Linux, no setup needed).
inline constexpr std::uint32_t kForeignLoopbackSource = 0x7F0000FDU;

struct StreamPacket {
  Nanos time_ns = 0;                 // the stream's own time (capture record time, sensor time)
  std::span<const std::byte> bytes;  // valid until the next call to next()
  bool position = false;             // for the second port: Velodyne position (8308), Ouster IMU (48 B)
  std::int64_t tag = -1;             // the truth record's part (truth_stream.hpp), -1 = none
                                     // kForeignTag: another sensor's packet (lidar.second_sensor)
  double rotor_deg = -1.0;           // first firing, degrees past the scan cut (< 0: unknown)
};

// Told what became of each tagged packet (truth_stream.hpp keeps the truth record with it).
class ReplayObserver {
 public:
  virtual ~ReplayObserver() = default;
  // A fault decided the packet's fate (fault 0: the rate faults, which have no plan id).
  virtual void fate(std::int64_t tag, truth::Fate fate, std::uint64_t fault) = 0;
  // Handed to sendmmsg at this CLOCK_REALTIME (the first time, for a duplicated packet).
  virtual void sent(std::int64_t tag, Nanos tx_ns) = 0;
  // A batch was handed to sendmmsg (after its sent() calls): what it records of them may be written
  // out now (a mock killed next must not take the parts it sent with it).
  virtual void batch_sent() {}
};

class PacketStream {
 public:
  virtual ~PacketStream() = default;
  virtual std::optional<StreamPacket> next() = 0;  // nullopt at the end
  virtual bool rewind() = 0;                        // back to the start (for --loop); false if it cannot
  [[nodiscard]] virtual std::string error() const { return {}; }  // why the stream ended early
};

// Opens a recording's raw LIDAR channel (`rig record --raw`: file, topic) as a packet stream; throws
// with the reason. lidar/ has no MCAP reader or CDR views (record/ and dds/ are not below it), so
// the `rig` executable hands one down (rig/src/lidar_recording_stream.hpp).
using RecordingOpener = std::function<std::unique_ptr<PacketStream>(const std::string& path, const std::string& topic)>;

// UDP payloads of a pcap file, position = destination port 8308 or a 48-byte Ouster IMU packet.
// Throws PcapError on open.
class PcapStream final : public PacketStream {
 public:
  explicit PcapStream(std::string path);
  ~PcapStream() override;
  std::optional<StreamPacket> next() override;
  bool rewind() override;
  [[nodiscard]] std::string error() const override;

 private:
  std::string path_;
  std::unique_ptr<PcapReader> reader_;
};

// An endless synthetic sensor (any vendor).
class SyntheticStream final : public PacketStream {
 public:
  explicit SyntheticStream(std::unique_ptr<SyntheticSensor> sensor) : sensor_(std::move(sensor)) {}
  explicit SyntheticStream(SyntheticVelodyne sensor)
      : sensor_(std::make_unique<SyntheticVelodyne>(std::move(sensor))) {}
  std::optional<StreamPacket> next() override;
  bool rewind() override { return true; }  // endless: nothing to rewind
  [[nodiscard]] const SyntheticSensor& sensor() const noexcept { return *sensor_; }

 private:
  std::unique_ptr<SyntheticSensor> sensor_;
};

struct ReplayOptions {
  double rate = 1.0;              // > 0; 2 = twice as fast as recorded
  bool loop = false;              // restart the stream at its end
  Nanos duration_ns = 0;          // stop after this wall time (0 = at the end of the stream)
  std::uint64_t max_packets = 0;  // stop after reading this many packets (0 = no limit)
  bool send_position = false;     // position packets to destination 1, else they are skipped
  FaultConfig faults;
  std::vector<NetFault> scheduled;   // the vocabulary's network faults (times: schedule offsets)
  ReplayObserver* observer = nullptr;
  std::size_t batch = 64;         // packets per sendmmsg when behind schedule
  Nanos lead_ns = 2'000'000;      // first packet this long after start()
  // The first packet is due at this CLOCK_MONOTONIC time instead (0: lead_ns after the call): a
  // synthetic sensor's timeline is vehicle time, and its packets leave when their time comes.
  Nanos start_monotonic_ns = 0;
};

struct ReplayStats {
  std::uint64_t read = 0;               // packets taken from the stream
  std::uint64_t sent = 0;               // datagrams handed to the kernel
  std::uint64_t sent_data = 0;
  std::uint64_t sent_position = 0;
  std::uint64_t skipped_position = 0;   // no position destination configured
  std::uint64_t send_errors = 0;
  std::uint64_t batches = 0;            // sendmmsg calls
  std::uint64_t late = 0;               // sent more than 1 ms after their deadline
  Nanos max_late_ns = 0;
  std::uint64_t loops = 0;              // completed passes when looping
  Nanos elapsed_ns = 0;
  FaultStats faults;
  std::string stream_error;             // the stream ended on an error (corrupt capture, ...)
  bool stopped = false;                 // ended by shutdown request
};

// Runs until the stream ends (without loop), the duration or packet limit is reached, or a
// shutdown is requested (sensor_rig::shutdown_requested()). Never throws once started.
ReplayStats run_replay(PacketStream& stream, UdpSender& sender, const ReplayOptions& options);

// One line: "replay: sent N datagrams (data D, position P) in T s, R pkt/s; faults: ...".
std::string summary_line(const ReplayStats& s);

}  // namespace sensor_rig::lidar::mock
