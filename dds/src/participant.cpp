#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>

#include "sensor_rig/common/log.hpp"
#include "sensor_rig/dds/participant.hpp"
#include "sensor_rig/dds/roudi.hpp"
#include "sensor_rig/dds/thread_scheduling.hpp"
#include "sensor_rig/dds/topic.hpp"
#include "security_qos.hpp"

#ifndef RIG_DEFAULT_SOURCE_DIR
#define RIG_DEFAULT_SOURCE_DIR "."
#endif

namespace sensor_rig::dds {
namespace {
std::string read_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read Cyclone DDS profile '" + path + "'");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Appended to the profile (Cyclone reads a list of files and XML fragments, later ones adding to
// earlier ones). Only iceoryx's warnings: its info level logs every endpoint.
constexpr const char* kShmFragment =
    "<CycloneDDS><Domain Id=\"any\"><SharedMemory><Enable>true</Enable><LogLevel>warn</LogLevel></SharedMemory>"
    "</Domain></CycloneDDS>";

void append(std::string& list, const std::string& item) {
  if (!item.empty()) list += (list.empty() ? "" : ",") + item;
}

// The realtime fragment for cfg, with a warning (once per process and priority) when refused.
std::string realtime_fragment(const DomainConfig& cfg) {
  std::string refused;
  std::string xml = realtime_threads_fragment(cfg.realtime_priority, &refused);
  static std::once_flag warned;
  if (!refused.empty())
    std::call_once(warned, [&] {
      log::warn("dds", "SCHED_FIFO " + std::to_string(cfg.realtime_priority) + " for Cyclone's threads refused (" +
                           refused + "), running them with normal priority");
    });
  return xml;
}

// What dds_create_domain gets: the profile's XML, plus the shared-memory and realtime fragments.
std::string domain_config(const std::string& profile, const DomainConfig& cfg) {
  std::string xml;
  if (!profile.empty()) {
    xml = read_file(profile);
  } else if (const char* uri = std::getenv("CYCLONEDDS_URI"); uri != nullptr) {
    xml = uri;
  }
  if (cfg.transport == Transport::kShm) append(xml, kShmFragment);
  append(xml, realtime_fragment(cfg));
  return xml;
}
}  // namespace

std::string to_string(Transport t) { return t == Transport::kShm ? "shm" : "udp"; }

// Cyclone allows one explicit configuration per domain id and process; the domain lives while a
// participant uses it (deleting it would delete every participant in it).
struct DomainHandle {
  std::string profile;
  Transport transport = Transport::kUdp;
  Entity domain;
};

namespace {
std::mutex g_domains_mutex;
std::map<dds_domainid_t, std::weak_ptr<DomainHandle>> g_domains;
}  // namespace

std::string resolve_profile(const DomainConfig& cfg) {
  if (!cfg.profile.empty()) return cfg.profile;
  if (const char* uri = std::getenv("CYCLONEDDS_URI"); uri != nullptr && *uri != '\0') return "";
  const char* src = std::getenv("RIG_SOURCE_DIR");
  const std::filesystem::path base = src != nullptr ? src : RIG_DEFAULT_SOURCE_DIR;
  return (base / "config/cyclonedds/loopback.xml").string();
}

std::string cyclone_uri(const DomainConfig& cfg) {
  const std::string profile = resolve_profile(cfg);
  std::string uri;
  if (!profile.empty()) {
    uri = "file://" + std::filesystem::absolute(profile).string();
  } else if (const char* env = std::getenv("CYCLONEDDS_URI"); env != nullptr) {
    uri = env;
  }
  if (cfg.transport == Transport::kShm) append(uri, kShmFragment);
  append(uri, realtime_fragment(cfg));
  return uri;
}

Participant::Participant(const DomainConfig& cfg, const SecurityConfig& explicit_security)
    : profile_(resolve_profile(cfg)) {
  // RIG_DDS_SECURITY secures every participant that does not bring its own identity (issue 28).
  const SecurityConfig security = explicit_security.enabled() ? explicit_security : security_from_environment();
  if (cfg.transport == Transport::kShm) {
    const auto probe = probe_roudi();
    if (!probe.answers) {
      throw std::runtime_error("DDS transport shm needs a running iceoryx RouDi: " +
                               (probe.pid != 0 ? probe.problem : std::string("no iox-roudi process")) +
                               " (`rig up` starts one for a config with transport shm)");
    }
  }
  if (!profile_.empty() || cfg.transport == Transport::kShm || cfg.realtime_priority > 0) {
    std::lock_guard lock(g_domains_mutex);
    domain_ = g_domains[cfg.domain_id].lock();
    if (!domain_) {
      const std::string xml = domain_config(profile_, cfg);
      domain_ = std::make_shared<DomainHandle>();
      domain_->profile = profile_;
      domain_->transport = cfg.transport;
      domain_->domain = Entity(check(dds_create_domain(cfg.domain_id, xml.c_str()), "dds_create_domain"));
      g_domains[cfg.domain_id] = domain_;
    } else if (domain_->profile != profile_ || domain_->transport != cfg.transport) {
      throw std::runtime_error("domain " + std::to_string(cfg.domain_id) + " already configured with '" +
                               domain_->profile + "' over " + to_string(domain_->transport) + ", cannot also use '" +
                               profile_ + "' over " + to_string(cfg.transport));
    }
  }
  if (!security.enabled()) {
    participant_ = Entity(check(dds_create_participant(cfg.domain_id, nullptr, nullptr), "dds_create_participant"));
    return;
  }
  const std::unique_ptr<dds_qos_t, decltype(&dds_delete_qos)> qos(dds_create_qos(), &dds_delete_qos);
  set_security_properties(qos.get(), security);
  const dds_entity_t p = dds_create_participant(cfg.domain_id, qos.get(), nullptr);
  if (p < 0) {
    // Cyclone logs the reason (certificate, signature, governance, permissions) on stderr.
    throw DdsError("DDS Security: participant with identity '" + security.identity + "' (" +
                       security.identity_certificate + ") refused; Cyclone's log above says why",
                   p);
  }
  participant_ = Entity(p);
}

std::string ros_to_dds_topic(const std::string& ros_name) {
  if (!ros_name.empty() && ros_name.front() == '/') return "rt" + ros_name;
  return "rt/" + ros_name;
}
std::string dds_to_ros_topic(const std::string& dds_name) {
  if (dds_name.rfind("rt/", 0) == 0) return dds_name.substr(2);
  return dds_name;
}

std::uint32_t publication_matched(dds_entity_t writer) {
  dds_publication_matched_status_t st{};
  if (dds_get_publication_matched_status(writer, &st) < 0) return 0;
  return st.current_count;
}
std::uint32_t subscription_matched(dds_entity_t reader) {
  dds_subscription_matched_status_t st{};
  if (dds_get_subscription_matched_status(reader, &st) < 0) return 0;
  return st.current_count;
}

}  // namespace sensor_rig::dds
