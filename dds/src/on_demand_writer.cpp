#include "sensor_rig/dds/on_demand_writer.hpp"

namespace sensor_rig::dds {

dds_listener_t* MatchedCount::make_listener(MatchedCount* count) {
  dds_listener_t* l = dds_create_listener(count);
  dds_lset_publication_matched(l, &MatchedCount::on_matched);
  return l;
}

void MatchedCount::on_matched(dds_entity_t, dds_publication_matched_status_t status, void* arg) {
  static_cast<MatchedCount*>(arg)->n_.store(status.current_count, std::memory_order_relaxed);
}

void MatchedCount::refresh(dds_entity_t writer) noexcept {
  dds_publication_matched_status_t st{};
  if (dds_get_publication_matched_status(writer, &st) >= 0) n_.store(st.current_count, std::memory_order_relaxed);
}

}  // namespace sensor_rig::dds
