// The governance and permissions XML of `rig security init` (OMG DDS Security 1.1, §9.4).
#include <ctime>
#include <sstream>

#include "sensor_rig/dds/security_init.hpp"

namespace sensor_rig::dds {
namespace {
// Domain ids 0..230: the most Cyclone's governance/permissions parser accepts (ROS 2 allows 232).
constexpr const char* kDomains = "<domains><id_range><min>0</min><max>230</max></id_range></domains>";

std::string utc(std::time_t t) {
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  return buf;
}

std::string write_rules(WriteProtection w) {
  if (w == WriteProtection::kNone) return {};
  const char* kind = w == WriteProtection::kSign ? "SIGN" : "NONE";
  std::string r;
  for (const char* expr : {"rt/vehicle/*", "rt/sensors/*", "rt/rig/*"}) {
    r += std::string("        <topic_rule>\n          <topic_expression>") + expr +
         "</topic_expression>\n"
         "          <enable_discovery_protection>false</enable_discovery_protection>\n"
         "          <enable_liveliness_protection>false</enable_liveliness_protection>\n"
         "          <enable_read_access_control>false</enable_read_access_control>\n"
         "          <enable_write_access_control>true</enable_write_access_control>\n"
         "          <metadata_protection_kind>" + kind + "</metadata_protection_kind>\n"
         "          <data_protection_kind>NONE</data_protection_kind>\n        </topic_rule>\n";
  }
  return r;
}

std::string topics(std::initializer_list<const char*> names) {
  std::string s = "<topics>";
  for (const char* n : names) s += std::string("<topic>") + n + "</topic>";
  return s + "</topics>";
}
}  // namespace

std::string to_governance_word(Protection p) {
  switch (p) {
    case Protection::kNone: return "NONE";
    case Protection::kSign: return "SIGN";
    case Protection::kEncrypt: return "ENCRYPT";
    case Protection::kSignOrigin: return "SIGN_WITH_ORIGIN_AUTHENTICATION";
    case Protection::kEncryptOrigin: return "ENCRYPT_WITH_ORIGIN_AUTHENTICATION";
  }
  return "SIGN_WITH_ORIGIN_AUTHENTICATION";
}

std::string identity_subject(const std::string& identity, const std::string& organization) {
  return "CN=" + identity + ",O=" + organization;
}

// One rule for the command topic, then everything else open. Command topic: only participants
// whose permissions grant it may read or write it (read and write access control), and every
// submessage carries a MAC per receiver (SIGN_WITH_ORIGIN_AUTHENTICATION): an authenticated reader
// that holds the writer's key still cannot forge a command as that writer (the default; `rig
// security init --cmd-protection` chooses another, dds/README.md has the costs). Not encrypted (a command
// is not secret; integrity is what matters), its endpoints announced only to authenticated
// participants (discovery protection). Other topics: no protection, so with
// allow_unauthenticated_participants an ordinary ROS 2 node reads the sensors as before.
//
// With write protection (issue 28), rt/vehicle/*, rt/sensors/* and rt/rig/* get write access
// control before `*`: a participant authenticated without a grant to publish them is refused by
// every secured peer. kAccess keeps them unprotected on the wire, so ordinary ROS 2 nodes still
// read them, and so secured readers still take an unauthenticated participant's writer unless they
// run with allow_unauthenticated false (a strict reader: `rig security init --strict-reader`);
// kSign adds metadata SIGN: every unauthenticated writer is refused, and every unauthenticated
// reader too (Cyclone 0.10.2 matches a protected writer only with authenticated readers).
std::string governance_xml(bool allow_unauthenticated, Protection command_protection, WriteProtection writes) {
  std::ostringstream x;
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
       "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
       "xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd\">\n"
       "  <domain_access_rules>\n    <domain_rule>\n      "
    << kDomains << "\n      <allow_unauthenticated_participants>" << (allow_unauthenticated ? "true" : "false")
    << "</allow_unauthenticated_participants>\n"
       "      <enable_join_access_control>true</enable_join_access_control>\n"
       "      <discovery_protection_kind>NONE</discovery_protection_kind>\n"
       "      <liveliness_protection_kind>NONE</liveliness_protection_kind>\n"
       "      <rtps_protection_kind>NONE</rtps_protection_kind>\n"
       "      <topic_access_rules>\n"
       "        <topic_rule>\n"
       "          <topic_expression>"
    << kProtectedCommandTopic
    << "</topic_expression>\n"
       "          <enable_discovery_protection>true</enable_discovery_protection>\n"
       "          <enable_liveliness_protection>false</enable_liveliness_protection>\n"
       "          <enable_read_access_control>true</enable_read_access_control>\n"
       "          <enable_write_access_control>true</enable_write_access_control>\n"
       "          <metadata_protection_kind>"
    << to_governance_word(command_protection)
    << "</metadata_protection_kind>\n"
       "          <data_protection_kind>NONE</data_protection_kind>\n"
       "        </topic_rule>\n"
    << write_rules(writes)
    << "        <topic_rule>\n"
       "          <topic_expression>*</topic_expression>\n"
       "          <enable_discovery_protection>false</enable_discovery_protection>\n"
       "          <enable_liveliness_protection>false</enable_liveliness_protection>\n"
       "          <enable_read_access_control>false</enable_read_access_control>\n"
       "          <enable_write_access_control>false</enable_write_access_control>\n"
       "          <metadata_protection_kind>NONE</metadata_protection_kind>\n"
       "          <data_protection_kind>NONE</data_protection_kind>\n"
       "        </topic_rule>\n"
       "      </topic_access_rules>\n    </domain_rule>\n  </domain_access_rules>\n</dds>\n";
  return x.str();
}

// Grants per role. Only the command topic is access controlled (governance); the other topics are
// listed so a grant reads as what the node does.
std::string permissions_xml(const std::string& identity, const std::string& subject, Role role,
                            std::time_t not_after) {
  const std::time_t now = std::time(nullptr);
  std::string rule;
  switch (role) {
    case Role::kBridge:
      // rt/vehicle/can/frames: the raw CAN channel, written while a recorder reads it (rig record --raw).
      rule = "<publish>" + topics({"rt/vehicle/dbw/status", "rt/vehicle/state", "rt/vehicle/can/frames", "rt/rig/stamps",
                                   "rt/diagnostics"}) +
             "</publish><subscribe>" + topics({kProtectedCommandTopic}) + "</subscribe>";
      break;
    case Role::kCommander:
      rule = "<publish>" + topics({kProtectedCommandTopic}) + "</publish><subscribe>" +
             topics({"rt/vehicle/dbw/status", "rt/vehicle/state"}) + "</subscribe>";
      break;
    case Role::kReader:
      rule = "<subscribe>" + topics({"*"}) + "</subscribe>";
      break;
    case Role::kNode:  // every rig node but the dbw processes; never the command topic (no wildcard over it)
      rule = "<publish>" + topics({"rt/sensors/*", "rt/rig/*", "rt/vehicle/state", "rt/vehicle/dbw/status",
                                   "rt/vehicle/can/frames", "rt/diagnostics"}) +
             "</publish><subscribe>" + topics({"*"}) + "</subscribe>";
      break;
  }
  std::ostringstream x;
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
       "<dds xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
       "xsi:noNamespaceSchemaLocation=\"http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd\">\n"
       "  <permissions>\n    <grant name=\""
    << identity << "\">\n      <subject_name>" << subject << "</subject_name>\n      <validity><not_before>"
    << utc(now - 86400) << "</not_before><not_after>" << utc(not_after)
    << "</not_after></validity>\n      <allow_rule>" << kDomains << rule
    << "</allow_rule>\n      <default>DENY</default>\n    </grant>\n  </permissions>\n</dds>\n";
  return x.str();
}

}  // namespace sensor_rig::dds
