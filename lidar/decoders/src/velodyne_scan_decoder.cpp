// The Velodyne decoder behind the vendor-neutral interface.
#include "velodyne_scan_decoder.hpp"

#include "sensor_rig/lidar/velodyne/calibration.hpp"
#include "sensor_rig/lidar/velodyne/decoder.hpp"
#include "sensor_rig/lidar/velodyne/packet_info.hpp"

namespace sensor_rig::lidar {
namespace {

class VelodyneScanDecoder final : public VendorScanDecoder<velodyne::Decoder> {
 public:
  explicit VelodyneScanDecoder(velodyne::DecoderConfig cfg)
      : VendorScanDecoder(velodyne::Decoder(std::move(cfg))),
        span_ns_(static_cast<Nanos>(velodyne::model_info(decoder_.config().model).block_us * 1000.0 *
                                    static_cast<double>(velodyne::kBlocksPerPacket))) {}

  [[nodiscard]] bool is_data_packet(const PacketView& p) const noexcept override {
    return p.dst_port != velodyne::kPositionPort && p.data.size() != velodyne::kPositionPacketSize;
  }
  [[nodiscard]] SensorTime packet_time(std::span<const std::byte> bytes) const noexcept override {
    const auto info = velodyne::read_packet_info(bytes);
    if (!info) return {};
    return {SensorTime::Kind::kMicrosSinceHour, info->sensor_time_us};
  }
  [[nodiscard]] Nanos packet_span_ns() const noexcept override { return span_ns_; }

 private:
  Nanos span_ns_;
};

}  // namespace

std::unique_ptr<ScanDecoder> make_velodyne_decoder(const DecoderOptions& o) {
  velodyne::DecoderConfig cfg;
  const auto model = velodyne::model_from_name(o.model);
  if (!model) throw DecoderConfigError("not a Velodyne model: " + o.model);
  cfg.model = *model;
  try {
    if (!o.calibration_text.empty())
      cfg.calibration = velodyne::parse_calibration(o.calibration_text, o.calibration_name);
    apply_common_options(o, cfg);
    return std::make_unique<VelodyneScanDecoder>(std::move(cfg));
  } catch (const DecoderConfigError&) {
    throw;
  } catch (const std::exception& e) {  // calibration errors, options out of range
    throw DecoderConfigError(e.what());
  }
}

}  // namespace sensor_rig::lidar
