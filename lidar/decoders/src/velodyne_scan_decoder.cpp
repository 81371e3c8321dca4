// The Velodyne decoder behind the vendor-neutral interface.
#include "velodyne_scan_decoder.hpp"

#include "sensor_rig/lidar/velodyne/calibration.hpp"
#include "sensor_rig/lidar/velodyne/decoder.hpp"
#include "sensor_rig/lidar/velodyne/packet_info.hpp"

namespace sensor_rig::lidar {
namespace {

class VelodyneScanDecoder final : public ScanDecoder {
 public:
  explicit VelodyneScanDecoder(velodyne::DecoderConfig cfg)
      : decoder_(std::move(cfg)),
        span_ns_(static_cast<Nanos>(velodyne::model_info(decoder_.config().model).block_us * 1000.0 *
                                    static_cast<double>(velodyne::kBlocksPerPacket))) {}

  std::optional<Scan> push(PacketView packet, Nanos packet_stamp) noexcept override {
    return decoder_.push(packet, packet_stamp);
  }
  std::optional<Scan> flush() noexcept override { return decoder_.flush(); }
  void recycle(std::vector<PointXYZIRT>&& buffer) noexcept override { decoder_.recycle(std::move(buffer)); }
  [[nodiscard]] bool is_data_packet(const PacketView& p) const noexcept override {
    return p.dst_port != velodyne::kPositionPort && p.data.size() != velodyne::kPositionPacketSize;
  }
  [[nodiscard]] SensorTime packet_time(std::span<const std::byte> bytes) const noexcept override {
    const auto info = velodyne::read_packet_info(bytes);
    if (!info) return {};
    return {SensorTime::Kind::kMicrosSinceHour, info->sensor_time_us};
  }
  [[nodiscard]] Nanos packet_span_ns() const noexcept override { return span_ns_; }
  [[nodiscard]] DecoderCounters counters() const noexcept override { return counters_from(decoder_.stats()); }
  [[nodiscard]] PacketStatus last_status() const noexcept override { return decoder_.last_status(); }

 private:
  velodyne::Decoder decoder_;
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
    cfg.returns = o.returns == "last"   ? velodyne::ReturnSelection::kLast
                  : o.returns == "dual" ? velodyne::ReturnSelection::kDual
                                        : velodyne::ReturnSelection::kStrongest;
    cfg.min_range_m = o.min_range_m;
    cfg.max_range_m = o.max_range_m;
    cfg.cut_angle_deg = o.cut_angle_deg;
    cfg.emit_partial_scans = o.emit_partial_scans;
    return std::make_unique<VelodyneScanDecoder>(std::move(cfg));
  } catch (const DecoderConfigError&) {
    throw;
  } catch (const std::exception& e) {  // calibration errors, options out of range
    throw DecoderConfigError(e.what());
  }
}

}  // namespace sensor_rig::lidar
