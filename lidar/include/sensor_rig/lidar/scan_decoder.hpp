#pragma once
// Vendor-neutral packet -> scan decoding: the interface every vendor's decoder implements, and the
// model registry the decode CLI and the driver use to pick one by name (SPEC §7 model names).
// Decoders are pure: no I/O, no clock reads; construction throws, push() never does.
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "sensor_rig/lidar/packet.hpp"
#include "sensor_rig/lidar/point_cloud.hpp"

namespace sensor_rig::lidar {

// Bad model, calibration or metadata: thrown by make_decoder(); the message says which and why.
struct DecoderConfigError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct DecoderOptions {
  std::string model;                 // SPEC §7 name: VLP-16, VLP-32C, HDL-32E, OS-LEGACY, OS, Pandar40P, PandarXT32
  std::string calibration_text;      // vendor calibration file contents; empty = the model's built-in values
  std::string calibration_name;      // file name, for messages
  std::string metadata_text;         // Ouster sensor metadata JSON (OS models need it)
  std::string metadata_name;
  std::string returns = "strongest";  // strongest | last | dual
  double min_range_m = 0.0;
  double max_range_m = std::numeric_limits<double>::infinity();
  double cut_angle_deg = 0.0;        // azimuth where a scan ends (vendors without azimuth cut by frame id)
  bool emit_partial_scans = false;   // also emit the scan started mid-rotation / ended by a time jump
};

// What a data packet says about its own time (the sensor's clock, before any mapping).
struct SensorTime {
  enum class Kind : std::uint8_t {
    kNone = 0,          // the packet carries no usable time: use the kernel receive time
    kMicrosSinceHour,   // Velodyne: µs since the top of the hour; the hour comes from GPRMC or the host
    kAbsoluteNs,        // Ouster, Hesai: ns since the Unix epoch in the sensor's clock (PTP, GPS or free-running)
  } kind = Kind::kNone;
  std::int64_t value = 0;
};

inline constexpr std::size_t kPacketStatusCount = 7;

struct DecoderCounters {
  std::uint64_t packets = 0;       // pushed
  std::uint64_t packets_used = 0;  // decoded into points
  std::uint64_t scans = 0;         // emitted
  std::uint64_t partial_scans_discarded = 0;
  std::array<std::uint64_t, kPacketStatusCount> by_status{};  // indexed by PacketStatus
  [[nodiscard]] std::uint64_t dropped() const noexcept { return packets - packets_used; }
};

// The common counters out of a vendor decoder's own stats (which may count more).
template <class VendorStats>
DecoderCounters counters_from(const VendorStats& s) noexcept {
  DecoderCounters c;
  c.packets = s.packets;
  c.packets_used = s.packets_used;
  c.scans = s.scans;
  c.partial_scans_discarded = s.partial_scans_discarded;
  for (std::size_t i = 0; i < c.by_status.size() && i < s.by_status.size(); ++i) c.by_status[i] = s.by_status[i];
  return c;
}

class ScanDecoder {
 public:
  virtual ~ScanDecoder() = default;
  // Decodes one data packet; returns the scan it completed, if any. `packet_stamp` is the vehicle
  // time of the packet's first firing (the caller maps packet_time() to vehicle time).
  virtual std::optional<Scan> push(PacketView packet, Nanos packet_stamp) noexcept = 0;
  // The scan in progress (partial), if it has any packets; resets.
  virtual std::optional<Scan> flush() noexcept = 0;
  // A published scan's buffer back for reuse (saves the page faults of a fresh multi-MB buffer).
  virtual void recycle(std::vector<PointXYZIRT>&& buffer) noexcept = 0;
  // Whether `packet` is a data packet of this sensor (not a position/IMU/telemetry packet).
  [[nodiscard]] virtual bool is_data_packet(const PacketView& packet) const noexcept = 0;
  [[nodiscard]] virtual SensorTime packet_time(std::span<const std::byte> bytes) const noexcept = 0;
  // First firing -> last firing of one data packet (host-time stamping subtracts it).
  [[nodiscard]] virtual Nanos packet_span_ns() const noexcept = 0;
  [[nodiscard]] virtual DecoderCounters counters() const noexcept = 0;
  [[nodiscard]] virtual PacketStatus last_status() const noexcept = 0;
};

struct ModelEntry {
  std::string_view name;    // as on the command line and in configs
  std::string_view vendor;  // velodyne | ouster | hesai
  std::uint16_t data_port;  // the vendor's default UDP port for data packets
  bool needs_metadata;      // true: DecoderOptions::metadata_text is required
  std::unique_ptr<ScanDecoder> (*make)(const DecoderOptions&);  // nullptr: not implemented yet
};

// Every model SPEC §7 names, implemented or not.
std::span<const ModelEntry> known_models() noexcept;
const ModelEntry* find_model(std::string_view name) noexcept;
// Comma-separated names of the implemented models, for messages.
std::string implemented_model_names();
// Throws DecoderConfigError: unknown model, model not implemented yet, bad calibration/metadata/options.
std::unique_ptr<ScanDecoder> make_decoder(const DecoderOptions& options);

}  // namespace sensor_rig::lidar
