// The vocabulary's field names on each vendor's packets (see packet_fields.hpp).
#include "sensor_rig/lidar/mock/packet_fields.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <stdexcept>

#include "sensor_rig/lidar/hesai/model.hpp"
#include "sensor_rig/lidar/hesai/packet.hpp"
#include "sensor_rig/lidar/mock/synthetic_hesai.hpp"
#include "sensor_rig/lidar/mock/synthetic_ouster.hpp"
#include "sensor_rig/lidar/mock/synthetic_velodyne.hpp"
#include "sensor_rig/lidar/ouster/profile.hpp"
#include "sensor_rig/lidar/velodyne/model.hpp"
#include "sensor_rig/lidar/velodyne/packet.hpp"

namespace sensor_rig::lidar::mock {
namespace {

constexpr std::array<std::string_view, 6> kNames{"time", "azimuth", "frame_id", "column_status", "udp_seq", "byte"};

FieldBytes of_spec(const ouster::FieldSpec& f) {
  const auto r = ouster::FieldReader::from(f);
  return {r.byte_offset, r.nbytes};
}

}  // namespace

std::optional<PacketField> packet_field_from_name(std::string_view name) noexcept {
  for (std::size_t i = 0; i < kNames.size(); ++i)
    if (kNames[i] == name) return static_cast<PacketField>(i);
  return std::nullopt;
}

std::string_view to_string(PacketField f) noexcept { return kNames[static_cast<std::size_t>(f)]; }

PacketFields::PacketFields(const SyntheticSensor& sensor) {
  if (const auto* v = dynamic_cast<const SyntheticVelodyne*>(&sensor)) {
    vendor_ = Vendor::kVelodyne;
    model_ = std::string(velodyne::model_info(v->config().model).name);
    packet_size_ = velodyne::kDataPacketSize;
    az_count_ = velodyne::kBlocksPerPacket;
    az_offset_ = offsetof(velodyne::RawBlock, azimuth);
    az_stride_ = sizeof(velodyne::RawBlock);
    time_ = FieldBytes{offsetof(velodyne::RawDataPacket, timestamp), 4};
    status_ = FieldBytes{offsetof(velodyne::RawBlock, flag), 2};  // nearest: the block's validity mark
  } else if (const auto* h = dynamic_cast<const SyntheticHesai*>(&sensor)) {
    vendor_ = Vendor::kHesai;
    const hesai::ModelInfo& mi = hesai::model_info(h->config().model);
    model_ = std::string(mi.name);
    packet_size_ = h->packet_size();
    az_count_ = static_cast<std::size_t>(mi.blocks);
    az_offset_ = mi.first_block + mi.block_azimuth;
    az_stride_ = mi.block_size;
    time_ = FieldBytes{mi.tail_timestamp, 4};
    if (h->config().model == hesai::Model::kPandarXT32) {
      seq_ = FieldBytes{offsetof(hesai::PacketXT32, udp_sequence), 4};
    } else {
      status_ = FieldBytes{mi.first_block, 2};  // the block's FF EE mark
      if (h->config().udp_sequence) seq_ = FieldBytes{sizeof(hesai::Packet40P), 4};
    }
  } else if (const auto* o = dynamic_cast<const SyntheticOuster*>(&sensor)) {
    vendor_ = Vendor::kOuster;
    const ouster::PacketLayout& l = o->layout();
    const bool legacy = l.header == ouster::HeaderType::kLegacy;
    model_ = legacy ? "OS-LEGACY" : "OS";
    packet_size_ = l.packet_size;
    const std::size_t col0 = l.column_offset(0);
    az_count_ = l.columns_per_packet;
    az_offset_ = col0 + 8;  // measurement id u16
    az_stride_ = l.col_size;
    time_ = FieldBytes{col0, 8};
    if (legacy) {
      frame_ = FieldBytes{col0 + 10, 2};
      status_ = FieldBytes{col0 + l.col_size - l.col_footer_size, 4};
      encoder_offset_ = col0 + 12;
    } else {
      frame_ = of_spec(ouster::header_spec(l.header).frame_id);
      status_ = FieldBytes{col0 + 10, 2};
    }
  } else {
    throw std::invalid_argument("packet fields: not a synthetic Velodyne, Hesai or Ouster sensor");
  }
}

FieldBytes PacketFields::locate(PacketField f, long byte_offset) const {
  const auto refuse = [&](const char* why) {
    return std::invalid_argument("lidar.corrupt field=" + std::string(to_string(f)) + ": " + model_ + " packets have no " +
                                 why);
  };
  switch (f) {
    case PacketField::kTime: return *time_;
    case PacketField::kAzimuth: return FieldBytes{az_offset_, 2};
    case PacketField::kFrameId:
      if (!frame_) throw refuse("frame id (use azimuth or time)");
      return *frame_;
    case PacketField::kColumnStatus:
      if (!status_) throw refuse("column status or block flag");
      return *status_;
    case PacketField::kUdpSeq:
      if (!seq_) throw refuse("UDP sequence");
      return *seq_;
    case PacketField::kByte:
      if (byte_offset >= static_cast<long>(packet_size_))
        throw std::invalid_argument("lidar.corrupt offset=" + std::to_string(byte_offset) + ": " + model_ + " packets have " +
                                    std::to_string(packet_size_) + " bytes");
      return FieldBytes{byte_offset < 0 ? 0 : static_cast<std::size_t>(byte_offset), 1};
  }
  return {};
}

void PacketFields::freeze_azimuth(std::span<std::byte> packet, std::span<const std::byte> frozen) const noexcept {
  if (packet.size() < packet_size_ || frozen.size() < packet_size_) return;
  for (std::size_t i = 0; i < az_count_; ++i) {
    std::memcpy(packet.data() + az_offset_ + i * az_stride_, frozen.data() + az_offset_, 2);
    if (encoder_offset_ != 0) std::memcpy(packet.data() + encoder_offset_ + i * az_stride_, frozen.data() + encoder_offset_, 4);
  }
}

}  // namespace sensor_rig::lidar::mock
