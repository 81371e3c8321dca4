// The Hesai decoder behind the vendor-neutral interface.
#include "sensor_rig/lidar/hesai/scan_decoder.hpp"

#include "sensor_rig/lidar/hesai/decoder.hpp"
#include "sensor_rig/lidar/hesai/packet.hpp"

namespace sensor_rig::lidar {
namespace {

class HesaiScanDecoder final : public VendorScanDecoder<hesai::Decoder> {
 public:
  explicit HesaiScanDecoder(hesai::DecoderConfig cfg) : VendorScanDecoder(hesai::Decoder(std::move(cfg))) {}

  [[nodiscard]] bool is_data_packet(const PacketView& p) const noexcept override {
    return p.dst_port != hesai::kGpsPort && p.data.size() != hesai::kGpsPacketSize;
  }
  // Sensor time of the packet's first firing: tail UTC date/time + µs plus the firing offset.
  [[nodiscard]] SensorTime packet_time(std::span<const std::byte> bytes) const noexcept override {
    const auto info = hesai::read_packet_info(bytes, decoder_.config().model);
    if (!info || !info->tail_time_ns) return {};
    return {SensorTime::Kind::kAbsoluteNs, *info->tail_time_ns + decoder_.first_firing_offset_ns(info->returns)};
  }
  // First firing -> tail time (when the packet is complete and sent), for the last seen return mode.
  [[nodiscard]] Nanos packet_span_ns() const noexcept override {
    return -decoder_.first_firing_offset_ns(decoder_.last_returns());
  }
};

}  // namespace

std::unique_ptr<ScanDecoder> make_hesai_decoder(const DecoderOptions& o) {
  const auto model = hesai::model_from_name(o.model);
  if (!model) throw DecoderConfigError("not a Hesai model: " + o.model);
  hesai::DecoderConfig cfg;
  cfg.model = *model;
  const std::string name = o.calibration_name.empty() ? "calibration" : o.calibration_name;
  if (!o.calibration_text.empty()) {
    if (hesai::is_firetime_csv(o.calibration_text)) {
      cfg.firing_times = hesai::parse_firetime_csv(o.calibration_text, name, *model);
    } else {
      cfg.calibration = hesai::parse_angle_csv(o.calibration_text, name, *model);
    }
  }
  apply_common_options(o, cfg);
  return std::make_unique<HesaiScanDecoder>(std::move(cfg));
}

}  // namespace sensor_rig::lidar
