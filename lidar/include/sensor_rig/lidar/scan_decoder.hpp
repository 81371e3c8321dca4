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
#include <utility>
#include <vector>

#include "sensor_rig/lidar/packet.hpp"
#include "sensor_rig/lidar/point_cloud.hpp"
#include "sensor_rig/lidar/return_selection.hpp"
#include "sensor_rig/lidar/scan_assembler.hpp"

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
  ReturnSelection returns = ReturnSelection::kStrongest;
  double min_range_m = 0.0;
  double max_range_m = std::numeric_limits<double>::infinity();
  double cut_angle_deg = 0.0;        // azimuth where a scan ends (vendors without azimuth cut by frame id)
  bool emit_partial_scans = false;   // also emit the scan started mid-rotation / ended by a time jump
  // The sensor's FOV setting (it sends only the clockwise arc start -> end, degrees); equal = the
  // whole turn. Only gaps inside it are missing packets (Velodyne, Hesai; Ouster: the metadata's
  // column window).
  double fov_start_deg = 0.0;
  double fov_end_deg = 0.0;
  AzimuthInterpolation azimuth = AzimuthInterpolation::kPerLaser;  // Velodyne only
};

// Copies the options every vendor's DecoderConfig shares: returns, range gate, partial scans and
// the cut angle (for the vendors that cut by azimuth).
template <class VendorConfig>
void apply_common_options(const DecoderOptions& o, VendorConfig& cfg) {
  cfg.returns = o.returns;
  cfg.min_range_m = o.min_range_m;
  cfg.max_range_m = o.max_range_m;
  if constexpr (requires { cfg.cut_angle_deg; }) cfg.cut_angle_deg = o.cut_angle_deg;
  if constexpr (requires { cfg.fov_start_deg; }) {
    cfg.fov_start_deg = o.fov_start_deg;
    cfg.fov_end_deg = o.fov_end_deg;
  }
  if constexpr (requires { cfg.interpolation; }) cfg.interpolation = o.azimuth;
  cfg.emit_partial_scans = o.emit_partial_scans;
}

// What a data packet says about its own time (the sensor's clock, before any mapping).
struct SensorTime {
  enum class Kind : std::uint8_t {
    kNone = 0,          // the packet carries no usable time: use the kernel receive time
    kMicrosSinceHour,   // Velodyne: µs since the top of the hour; the hour comes from GPRMC or the host
    kAbsoluteNs,        // Ouster, Hesai: ns since the Unix epoch in the sensor's clock (PTP, GPS or free-running)
  } kind = Kind::kNone;
  std::int64_t value = 0;
};

// The common counters of every vendor decoder (a vendor's own stats may count more).
using DecoderCounters = ScanStats;

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

// ScanDecoder over a vendor's Decoder (a DecoderPimpl): push, flush, recycle, counters and
// last_status forward to it; the vendor adds is_data_packet, packet_time and packet_span_ns.
template <class VendorDecoder>
class VendorScanDecoder : public ScanDecoder {
 public:
  explicit VendorScanDecoder(VendorDecoder&& decoder) noexcept : decoder_(std::move(decoder)) {}

  std::optional<Scan> push(PacketView packet, Nanos packet_stamp) noexcept override {
    return decoder_.push(packet, packet_stamp);
  }
  std::optional<Scan> flush() noexcept override { return decoder_.flush(); }
  void recycle(std::vector<PointXYZIRT>&& buffer) noexcept override { decoder_.recycle(std::move(buffer)); }
  [[nodiscard]] DecoderCounters counters() const noexcept override { return decoder_.stats(); }
  [[nodiscard]] PacketStatus last_status() const noexcept override { return decoder_.last_status(); }

 protected:
  VendorDecoder decoder_;
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
