#include "sensor_rig/dds/discovery.hpp"

#include <array>

namespace sensor_rig::dds {
namespace {

constexpr std::size_t kBatch = 16;

// Takes up to kBatch samples of a built-in topic reader as loans; fn(sample, info) per sample.
template <class T, class F>
std::size_t take_builtin(dds_entity_t reader, F&& fn) {
  std::array<void*, kBatch> ptrs{};
  std::array<dds_sample_info_t, kBatch> infos{};
  const dds_return_t n = dds_take(reader, ptrs.data(), infos.data(), kBatch, kBatch);
  if (n <= 0) return 0;
  for (dds_return_t i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    fn(*static_cast<const T*>(ptrs[k]), infos[k]);
  }
  dds_return_loan(reader, ptrs.data(), n);
  return static_cast<std::size_t>(n);
}

}  // namespace

std::string guid_to_hex(const dds_guid_t& guid) {
  constexpr char kHex[] = "0123456789abcdef";
  std::string s;
  s.reserve(2 * sizeof guid.v);
  for (const std::uint8_t b : guid.v) {
    s += kHex[b >> 4];
    s += kHex[b & 0xf];
  }
  return s;
}

DiscoveryReader::DiscoveryReader(const Participant& p)
    : participants_(check(dds_create_reader(p.handle(), DDS_BUILTIN_TOPIC_DCPSPARTICIPANT, nullptr, nullptr),
                          "builtin participant reader")),
      publications_(check(dds_create_reader(p.handle(), DDS_BUILTIN_TOPIC_DCPSPUBLICATION, nullptr, nullptr),
                          "builtin publication reader")) {}

void DiscoveryReader::take_participants() {
  const auto on_participant = [&](const dds_builtintopic_participant_t& s, const dds_sample_info_t& info) {
    const std::string guid = guid_to_hex(s.key);
    if (!info.valid_data || info.instance_state != DDS_IST_ALIVE) {
      hosts_.erase(guid);
      return;
    }
    char* host = nullptr;
    if (s.qos != nullptr && dds_qget_prop(s.qos, "__Hostname", &host) && host != nullptr) {
      hosts_[guid] = host;
      dds_free(host);
    }
  };
  while (take_builtin<dds_builtintopic_participant_t>(participants_.handle(), on_participant) == kBatch) continue;
}

std::vector<Publication> DiscoveryReader::take(std::size_t max) {
  // SPDP (participants) comes before SEDP (endpoints): the writer's participant is normally known.
  take_participants();
  std::vector<Publication> out;
  while (out.size() < max) {
    const std::size_t n = take_builtin<dds_builtintopic_endpoint_t>(
        publications_.handle(), [&](const dds_builtintopic_endpoint_t& s, const dds_sample_info_t& info) {
          Publication pub;
          pub.writer_guid = guid_to_hex(s.key);
          if (!info.valid_data || info.instance_state != DDS_IST_ALIVE) {
            pub.alive = false;
            out.push_back(std::move(pub));
            return;
          }
          pub.topic = s.topic_name != nullptr ? s.topic_name : "";
          pub.type = s.type_name != nullptr ? s.type_name : "";
          pub.participant_guid = guid_to_hex(s.participant_key);
          if (const auto it = hosts_.find(pub.participant_guid); it != hosts_.end()) pub.host = it->second;
          dds_reliability_kind_t kind = DDS_RELIABILITY_RELIABLE;
          dds_duration_t blocking = 0;
          if (s.qos != nullptr && dds_qget_reliability(s.qos, &kind, &blocking) && kind == DDS_RELIABILITY_BEST_EFFORT)
            pub.reliability = QosSpec::Reliability::kBestEffort;
          dds_durability_kind_t durability = DDS_DURABILITY_VOLATILE;
          if (s.qos != nullptr && dds_qget_durability(s.qos, &durability) && durability != DDS_DURABILITY_VOLATILE)
            pub.durability = QosSpec::Durability::kTransientLocal;
          dds_history_kind_t history = DDS_HISTORY_KEEP_LAST;
          int32_t depth = 1;
          if (s.qos != nullptr && dds_qget_history(s.qos, &history, &depth))
            pub.depth = history == DDS_HISTORY_KEEP_ALL ? 0 : depth;
          out.push_back(std::move(pub));
        });
    if (n < kBatch) break;
  }
  return out;
}

}  // namespace sensor_rig::dds
