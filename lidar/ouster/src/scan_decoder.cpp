// The Ouster decoder behind the vendor-neutral interface. The cut angle does not apply: Ouster
// scans are cut by frame id (the sensor starts a frame at encoder 0).
#include "sensor_rig/lidar/ouster/scan_decoder.hpp"

#include "sensor_rig/lidar/ouster/decoder.hpp"
#include "sensor_rig/lidar/ouster/metadata.hpp"

namespace sensor_rig::lidar {
namespace {

class OusterScanDecoder final : public VendorScanDecoder<ouster::Decoder> {
 public:
  explicit OusterScanDecoder(ouster::DecoderConfig cfg) : VendorScanDecoder(ouster::Decoder(std::move(cfg))) {
    const auto& m = decoder_.config().metadata;
    lidar_port_ = m.udp_port_lidar;
    imu_port_ = m.udp_port_imu;
  }

  // IMU packets come on their own port (7503) and, in the LEGACY IMU profile, are 48 bytes.
  [[nodiscard]] bool is_data_packet(const PacketView& p) const noexcept override {
    if (p.data.size() == ouster::kLegacyImuPacketSize && p.data.size() != decoder_.layout().packet_size) return false;
    return !(imu_port_ != 0 && imu_port_ != lidar_port_ && p.dst_port == imu_port_);
  }
  [[nodiscard]] SensorTime packet_time(std::span<const std::byte> bytes) const noexcept override {
    const auto t = decoder_.first_column_time(bytes);
    if (!t || *t > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) return {};
    return {SensorTime::Kind::kAbsoluteNs, static_cast<std::int64_t>(*t)};
  }
  [[nodiscard]] Nanos packet_span_ns() const noexcept override { return decoder_.packet_span_ns(); }

 private:
  std::uint16_t lidar_port_ = 0;
  std::uint16_t imu_port_ = 0;
};

}  // namespace

std::unique_ptr<ScanDecoder> make_ouster_decoder(const DecoderOptions& o) {
  if (o.model != "OS-LEGACY" && o.model != "OS") throw DecoderConfigError("not an Ouster model: " + o.model);
  if (o.metadata_text.empty())
    throw DecoderConfigError("model " + o.model + " needs the sensor metadata JSON (--metadata)");
  const std::string name = o.metadata_name.empty() ? "metadata" : o.metadata_name;
  ouster::DecoderConfig cfg;
  cfg.metadata = ouster::parse_metadata(o.metadata_text, name);  // MetadataError is a DecoderConfigError
  const bool legacy = cfg.metadata.profile == ouster::Profile::kLegacy;
  if (legacy != (o.model == "OS-LEGACY")) {
    throw DecoderConfigError(name + ": key 'udp_profile_lidar': " +
                             std::string(ouster::profile_spec(cfg.metadata.profile).name) + " is " +
                             (legacy ? "the legacy profile: use model OS-LEGACY" : "not LEGACY: use model OS"));
  }
  apply_common_options(o, cfg);  // no cut angle: Ouster scans are cut by frame id
  try {
    return std::make_unique<OusterScanDecoder>(std::move(cfg));
  } catch (const std::invalid_argument& e) {  // options out of range
    throw DecoderConfigError(e.what());
  }
}

}  // namespace sensor_rig::lidar
