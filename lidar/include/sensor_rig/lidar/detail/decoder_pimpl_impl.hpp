#pragma once
// DecoderPimpl's members, for the vendor decoder.cpp that instantiates it (see decoder_pimpl.hpp).
// Impl must have:
//   Impl(Config)                                     validates (throws), precomputes tables
//   PacketStatus check(std::span<const std::byte>) const noexcept     the packet's checks
//   std::optional<Scan> decode(const PacketView&, Nanos) noexcept     a checked packet into scans
//   void restart() noexcept                          forgets the stream (flush)
//   members cfg (Config), stats (Stats, a ScanStats), last (PacketStatus), scans (ScanAssembler),
//   gaps (StreamGap: told of every packet pushed, kept or rejected, after its decode)
#include <utility>

#include "sensor_rig/lidar/decoder_pimpl.hpp"
#include "sensor_rig/lidar/stream_gap.hpp"

namespace sensor_rig::lidar {

template <class Impl, class Config, class Stats>
DecoderPimpl<Impl, Config, Stats>::DecoderPimpl(Config config) : impl_(std::make_unique<Impl>(std::move(config))) {}
template <class Impl, class Config, class Stats>
DecoderPimpl<Impl, Config, Stats>::~DecoderPimpl() = default;
template <class Impl, class Config, class Stats>
DecoderPimpl<Impl, Config, Stats>::DecoderPimpl(DecoderPimpl&&) noexcept = default;
template <class Impl, class Config, class Stats>
DecoderPimpl<Impl, Config, Stats>& DecoderPimpl<Impl, Config, Stats>::operator=(DecoderPimpl&&) noexcept = default;

template <class Impl, class Config, class Stats>
std::optional<Scan> DecoderPimpl<Impl, Config, Stats>::push(PacketView packet, Nanos packet_stamp) noexcept {
  Impl& d = *impl_;
  d.last = d.check(packet.data);
  std::optional<Scan> out;
  const std::uint32_t rejected = d.scans.rejected_since_kept();
  if (d.scans.accept(d.last)) out = d.decode(packet, packet_stamp);
  d.gaps.heard(rx_times(packet), rejected, d.scans.rejected_since_kept());  // after: decode judged the gap before this packet
  return out;
}
template <class Impl, class Config, class Stats>
std::optional<Scan> DecoderPimpl<Impl, Config, Stats>::flush() noexcept {
  impl_->restart();
  impl_->gaps.forget();
  return impl_->scans.flush();
}
template <class Impl, class Config, class Stats>
void DecoderPimpl<Impl, Config, Stats>::recycle(std::vector<PointXYZIRT>&& buffer) noexcept {
  impl_->scans.recycle(std::move(buffer));
}
template <class Impl, class Config, class Stats>
PacketStatus DecoderPimpl<Impl, Config, Stats>::last_status() const noexcept {
  return impl_->last;
}
template <class Impl, class Config, class Stats>
const Stats& DecoderPimpl<Impl, Config, Stats>::stats() const noexcept {
  return impl_->stats;
}
template <class Impl, class Config, class Stats>
const Config& DecoderPimpl<Impl, Config, Stats>::config() const noexcept {
  return impl_->cfg;
}

}  // namespace sensor_rig::lidar
