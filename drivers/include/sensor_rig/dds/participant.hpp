#pragma once
// A DDS domain participant configured from a Cyclone XML profile (file path) or CYCLONEDDS_URI.
#include <string>

#include "sensor_rig/dds/entity.hpp"

namespace sensor_rig::dds {

struct DomainConfig {
  dds_domainid_t domain_id = 0;
  // Cyclone XML file. Empty: $CYCLONEDDS_URI if set, else the rig's loopback profile
  // ($RIG_SOURCE_DIR or the source tree's config/cyclonedds/loopback.xml).
  std::string profile;
};

// Resolves the profile the way Participant does (for logs and diagnostics).
std::string resolve_profile(const DomainConfig& cfg);

class Participant {
 public:
  explicit Participant(const DomainConfig& cfg = {});
  [[nodiscard]] dds_entity_t handle() const noexcept { return participant_.handle(); }
  [[nodiscard]] const std::string& profile() const noexcept { return profile_; }

 private:
  std::string profile_;
  Entity domain_;
  Entity participant_;
};

}  // namespace sensor_rig::dds
