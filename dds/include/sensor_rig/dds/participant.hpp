#pragma once
// A DDS domain participant configured from a Cyclone XML profile (file path) or CYCLONEDDS_URI.
#include <memory>
#include <string>

#include "sensor_rig/dds/entity.hpp"
#include "sensor_rig/dds/security.hpp"

namespace sensor_rig::dds {

// How samples travel between processes on this host. udp: Cyclone's network path (loopback);
// shm: iceoryx shared memory where Cyclone can (a RouDi must run; see roudi.hpp), UDP elsewhere.
enum class Transport { kUdp, kShm };
std::string to_string(Transport t);

struct DomainConfig {
  dds_domainid_t domain_id = 0;
  // Cyclone XML file. Empty: $CYCLONEDDS_URI if set, else the rig's loopback profile
  // ($RIG_SOURCE_DIR or the source tree's config/cyclonedds/loopback.xml).
  std::string profile;
  Transport transport = Transport::kUdp;  // shm: the profile plus <SharedMemory><Enable>true
  // > 0: Cyclone's receive, user-delivery and timed-event threads run SCHED_FIFO at this priority
  // (thread_scheduling.hpp); refused (no root / CAP_SYS_NICE / RLIMIT_RTPRIO): a warning, normal threads.
  int realtime_priority = 0;
};

// Resolves the profile the way Participant does (for logs and diagnostics).
std::string resolve_profile(const DomainConfig& cfg);
// The Cyclone configuration for cfg as a CYCLONEDDS_URI value (the profile file, then the shared
// memory fragment when shm), for child processes that take their DDS configuration from there.
std::string cyclone_uri(const DomainConfig& cfg);

struct DomainHandle;  // a configured Cyclone domain, shared by the participants that use it

class Participant {
 public:
  // With Transport::kShm, throws std::runtime_error when no RouDi answers (iceoryx would wait 60 s
  // for one and then abort the process). With security, throws DdsError when Cyclone refuses the
  // participant (a plugin that does not load, a certificate or signed document that does not verify).
  explicit Participant(const DomainConfig& cfg = {}) : Participant(cfg, SecurityConfig{}) {}
  // With DDS Security for this participant (not the domain: secured and ordinary participants may
  // share a process); off when security is empty. See security.hpp.
  Participant(const DomainConfig& cfg, const SecurityConfig& security);
  [[nodiscard]] dds_entity_t handle() const noexcept { return participant_.handle(); }
  [[nodiscard]] const std::string& profile() const noexcept { return profile_; }

 private:
  std::string profile_;
  std::shared_ptr<DomainHandle> domain_;  // outlives participant_ (declared first, destroyed last)
  Entity participant_;
};

}  // namespace sensor_rig::dds
