// The Hesai decoder behind the vendor-neutral interface.
#include "sensor_rig/lidar/hesai/scan_decoder.hpp"

#include "sensor_rig/lidar/hesai/decoder.hpp"
#include "sensor_rig/lidar/hesai/packet.hpp"

namespace sensor_rig::lidar {
namespace {

class HesaiScanDecoder final : public ScanDecoder {
 public:
  explicit HesaiScanDecoder(hesai::DecoderConfig cfg) : decoder_(std::move(cfg)) {}

  std::optional<Scan> push(PacketView packet, Nanos packet_stamp) noexcept override {
    return decoder_.push(packet, packet_stamp);
  }
  std::optional<Scan> flush() noexcept override { return decoder_.flush(); }
  void recycle(std::vector<PointXYZIRT>&& buffer) noexcept override { decoder_.recycle(std::move(buffer)); }
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
  [[nodiscard]] DecoderCounters counters() const noexcept override { return counters_from(decoder_.stats()); }
  [[nodiscard]] PacketStatus last_status() const noexcept override { return decoder_.last_status(); }

 private:
  hesai::Decoder decoder_;
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
  if (o.returns == "dual") {
    cfg.returns = hesai::ReturnSelection::kDual;
  } else if (o.returns == "last") {
    cfg.returns = hesai::ReturnSelection::kLast;
  } else if (o.returns == "strongest") {
    cfg.returns = hesai::ReturnSelection::kStrongest;
  } else {
    throw DecoderConfigError("return mode must be strongest, last or dual, not '" + o.returns + "'");
  }
  cfg.min_range_m = o.min_range_m;
  cfg.max_range_m = o.max_range_m;
  cfg.cut_angle_deg = o.cut_angle_deg;
  cfg.emit_partial_scans = o.emit_partial_scans;
  return std::make_unique<HesaiScanDecoder>(std::move(cfg));
}

}  // namespace sensor_rig::lidar
