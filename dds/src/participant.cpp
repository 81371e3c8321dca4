#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>

#include "sensor_rig/common/log.hpp"
#include "sensor_rig/dds/participant.hpp"
#include "sensor_rig/dds/topic.hpp"

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
}  // namespace

// Cyclone allows one explicit configuration per domain id and process; the domain lives while a
// participant uses it (deleting it would delete every participant in it).
struct DomainHandle {
  std::string profile;
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

Participant::Participant(const DomainConfig& cfg) : profile_(resolve_profile(cfg)) {
  if (!profile_.empty()) {
    std::lock_guard lock(g_domains_mutex);
    domain_ = g_domains[cfg.domain_id].lock();
    if (!domain_) {
      const std::string xml = read_file(profile_);
      domain_ = std::make_shared<DomainHandle>();
      domain_->profile = profile_;
      domain_->domain = Entity(check(dds_create_domain(cfg.domain_id, xml.c_str()), "dds_create_domain"));
      g_domains[cfg.domain_id] = domain_;
    } else if (domain_->profile != profile_) {
      throw std::runtime_error("domain " + std::to_string(cfg.domain_id) + " already configured with '" +
                               domain_->profile + "', cannot also use '" + profile_ + "'");
    }
  }
  participant_ = Entity(check(dds_create_participant(cfg.domain_id, nullptr, nullptr), "dds_create_participant"));
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
