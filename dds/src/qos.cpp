#include <sstream>

#include "sensor_rig/common/config_node.hpp"
#include "sensor_rig/dds/qos.hpp"

namespace sensor_rig::dds {

QosSpec QosSpec::from_config(const config::Node& node, QosSpec d) {
  node.allow_keys({"reliability", "durability", "depth", "max_blocking_ms", "deadline_ms", "lifespan_ms"});
  QosSpec q = d;
  const std::string rel = node.get_choice("reliability", {"reliable", "best_effort"},
                                          d.reliability == Reliability::kReliable ? "reliable" : "best_effort");
  q.reliability = rel == "reliable" ? Reliability::kReliable : Reliability::kBestEffort;
  const std::string dur = node.get_choice("durability", {"volatile", "transient_local"},
                                          d.durability == Durability::kVolatile ? "volatile" : "transient_local");
  q.durability = dur == "volatile" ? Durability::kVolatile : Durability::kTransientLocal;
  q.depth = static_cast<int>(node.get_int("depth", 0, 100000, d.depth));
  q.max_blocking_ms = node.get_int("max_blocking_ms", 0, 60000, d.max_blocking_ms);
  q.deadline_ms = node.get_int("deadline_ms", 0, 3600000, d.deadline_ms);
  q.lifespan_ms = node.get_int("lifespan_ms", 0, 3600000, d.lifespan_ms);
  return q;
}

QosPtr make_qos(const QosSpec& s) {
  QosPtr q(dds_create_qos());
  if (s.reliability == QosSpec::Reliability::kReliable)
    dds_qset_reliability(q.get(), DDS_RELIABILITY_RELIABLE, DDS_MSECS(s.max_blocking_ms));
  else
    dds_qset_reliability(q.get(), DDS_RELIABILITY_BEST_EFFORT, 0);
  dds_qset_durability(q.get(), s.durability == QosSpec::Durability::kVolatile ? DDS_DURABILITY_VOLATILE
                                                                               : DDS_DURABILITY_TRANSIENT_LOCAL);
  if (s.depth > 0)
    dds_qset_history(q.get(), DDS_HISTORY_KEEP_LAST, s.depth);
  else
    dds_qset_history(q.get(), DDS_HISTORY_KEEP_ALL, DDS_LENGTH_UNLIMITED);
  if (s.deadline_ms > 0) dds_qset_deadline(q.get(), DDS_MSECS(s.deadline_ms));
  if (s.lifespan_ms > 0) dds_qset_lifespan(q.get(), DDS_MSECS(s.lifespan_ms));
  // XCDR1 only: what rmw_cyclonedds speaks.
  const dds_data_representation_id_t rep = DDS_DATA_REPRESENTATION_XCDR1;
  dds_qset_data_representation(q.get(), 1, &rep);
  return q;
}

std::string to_string(const QosSpec& s) {
  std::ostringstream o;
  o << (s.reliability == QosSpec::Reliability::kReliable ? "reliable" : "best_effort") << ","
    << (s.durability == QosSpec::Durability::kVolatile ? "volatile" : "transient_local") << ","
    << (s.depth > 0 ? "keep_last(" + std::to_string(s.depth) + ")" : std::string("keep_all"));
  return o.str();
}

}  // namespace sensor_rig::dds
