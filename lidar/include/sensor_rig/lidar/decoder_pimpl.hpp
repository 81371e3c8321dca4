#pragma once
// The public face every vendor's packet -> scan decoder shares: a pimpl base with push / flush /
// recycle / last_status / stats / config. A vendor declares
//
//   struct DecoderImpl;  // in its decoder.cpp
//   class Decoder : public DecoderPimpl<DecoderImpl, DecoderConfig, DecoderStats> { ... extras ... };
//   extern template class DecoderPimpl<DecoderImpl, DecoderConfig, DecoderStats>;
//
// and its decoder.cpp defines DecoderImpl, includes sensor_rig/lidar/detail/decoder_pimpl_impl.hpp
// and instantiates the template explicitly (the hot path stays in one translation unit).
#include <memory>
#include <optional>
#include <vector>

#include "sensor_rig/lidar/packet.hpp"
#include "sensor_rig/lidar/point_cloud.hpp"

namespace sensor_rig::lidar {

template <class Impl, class Config, class Stats>
class DecoderPimpl {
 public:
  // Decodes one data packet. Returns the scan the packet completed, if any. Never throws;
  // a rejected packet is counted (stats(), the scan's `dropped`) and last_status() says why.
  std::optional<Scan> push(PacketView packet, Nanos packet_stamp) noexcept;
  // Returns the scan in progress (partial) and resets; nullopt if it has no packets.
  std::optional<Scan> flush() noexcept;
  // Hands a published scan's point buffer back for reuse (optional): the next scan writes into it
  // instead of a fresh allocation, which saves the page faults of a new multi-MB buffer per scan.
  void recycle(std::vector<PointXYZIRT>&& buffer) noexcept;

  [[nodiscard]] PacketStatus last_status() const noexcept;
  [[nodiscard]] const Stats& stats() const noexcept;
  [[nodiscard]] const Config& config() const noexcept;

 protected:
  explicit DecoderPimpl(Config config);  // throws what Impl's constructor throws
  ~DecoderPimpl();
  DecoderPimpl(DecoderPimpl&&) noexcept;
  DecoderPimpl& operator=(DecoderPimpl&&) noexcept;
  DecoderPimpl(const DecoderPimpl&) = delete;
  DecoderPimpl& operator=(const DecoderPimpl&) = delete;

  [[nodiscard]] const Impl& impl() const noexcept { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace sensor_rig::lidar
