#include "sensor_rig/dds/waitset.hpp"

namespace sensor_rig::dds {

WaitSet::WaitSet(const Participant& p)
    : waitset_(check(dds_create_waitset(p.handle()), "dds_create_waitset")),
      guard_(check(dds_create_guardcondition(p.handle()), "dds_create_guardcondition")) {}

WaitSet::~WaitSet() {
  // Conditions go before the readers they belong to; detach them from the waitset first.
  for (const auto& c : conditions_) dds_waitset_detach(waitset_.handle(), c.handle());
}

void WaitSet::attach_reader(dds_entity_t reader, std::int64_t tag) {
  conditions_.emplace_back(check(dds_create_readcondition(reader, DDS_ANY_STATE), "dds_create_readcondition"));
  check(dds_waitset_attach(waitset_.handle(), conditions_.back().handle(), static_cast<dds_attach_t>(tag)),
        "dds_waitset_attach");
  triggered_.resize(conditions_.size() + 1);
}

void WaitSet::detach_reader(dds_entity_t reader) noexcept {
  for (auto it = conditions_.begin(); it != conditions_.end();) {
    if (dds_get_parent(it->handle()) == reader) {
      dds_waitset_detach(waitset_.handle(), it->handle());
      it = conditions_.erase(it);  // the Entity deletes the condition
    } else {
      ++it;
    }
  }
  triggered_.resize(conditions_.size() + 1);
}

void WaitSet::attach_guard(std::int64_t tag) {
  check(dds_waitset_attach(waitset_.handle(), guard_.handle(), static_cast<dds_attach_t>(tag)), "dds_waitset_attach");
  triggered_.resize(conditions_.size() + 1);
}

void WaitSet::wake() noexcept { dds_set_guardcondition(guard_.handle(), true); }

void WaitSet::clear_guard() noexcept { dds_set_guardcondition(guard_.handle(), false); }

void WaitSet::wait(std::vector<std::int64_t>& tags, Nanos timeout_ns) {
  tags.clear();
  if (triggered_.empty()) triggered_.resize(1);
  const dds_return_t n = dds_waitset_wait(waitset_.handle(), triggered_.data(), triggered_.size(), timeout_ns);
  for (dds_return_t k = 0; k < n && static_cast<std::size_t>(k) < triggered_.size(); ++k)
    tags.push_back(static_cast<std::int64_t>(triggered_[static_cast<std::size_t>(k)]));
}

}  // namespace sensor_rig::dds
