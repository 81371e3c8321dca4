// DDS Security for a participant: the identity's files and Cyclone's plugins, as the participant
// QoS properties `dds.sec.*` (Cyclone 0.10's documented per-participant form; the domain's XML
// profile stays the same for secured and ordinary participants in one process).
#include "sensor_rig/dds/security.hpp"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "sensor_rig/dds/security_init.hpp"
#include "security_checks.hpp"
#include "security_qos.hpp"

#ifndef RIG_DDS_SECURITY_PLUGIN_DIR
#define RIG_DDS_SECURITY_PLUGIN_DIR ""
#endif

namespace sensor_rig::dds {
namespace fs = std::filesystem;

SecurityConfig security_files(const std::string& dir, const std::string& identity) {
  if (identity.empty() || identity.find('/') != std::string::npos || identity == "." || identity == "..")
    throw std::runtime_error("DDS Security: invalid identity name '" + identity + "'");
  const fs::path d(dir);
  SecurityConfig c;
  c.identity = identity;
  c.identity_ca = (d / "identity_ca.pem").string();
  c.permissions_ca = (d / "permissions_ca.pem").string();
  // A strict reader (`init --strict-reader NAME`) has a governance of its own.
  c.governance = fs::is_regular_file(d / identity / "governance.p7s") ? (d / identity / "governance.p7s").string()
                                                                      : (d / "governance.p7s").string();
  c.identity_certificate = (d / identity / "cert.pem").string();
  c.private_key = (d / identity / "key.pem").string();
  c.permissions = (d / identity / "permissions.p7s").string();
  c.crl = (d / "identity_crl.pem").string();
  std::string missing;
  for (const auto* f : {&c.identity_ca, &c.permissions_ca, &c.governance, &c.identity_certificate, &c.private_key,
                        &c.permissions, &c.crl}) {
    if (!fs::is_regular_file(*f)) missing += (missing.empty() ? "" : ", ") + *f;
  }
  if (!missing.empty()) {
    throw std::runtime_error("DDS Security: identity '" + identity + "' in '" + dir + "': missing " + missing +
                             " (`rig security init DIR` makes a CA, identities, signed permissions and the "
                             "revocation list; for a directory made before the list existed, `rig security revoke "
                             "DIR` without a name writes an empty one)");
  }
  check_private_key_mode(c.private_key, identity);
  std::ifstream gov(c.governance, std::ios::binary);
  std::ostringstream text;
  text << gov.rdbuf();
  check_governance(text.str(), c.governance);  // the signed text, as Cyclone will read it
  return c;
}

SecurityConfig security_from_environment() {
  const char* env = std::getenv("RIG_DDS_SECURITY");
  if (env == nullptr || *env == '\0') return {};
  const std::string v(env);
  const auto colon = v.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == v.size())
    throw std::runtime_error("RIG_DDS_SECURITY='" + v + "': expected DIR:IDENTITY");
  return security_files(v.substr(0, colon), v.substr(colon + 1));
}

std::string security_plugin_dir() {
  if (const char* env = std::getenv("RIG_DDS_SECURITY_PLUGINS"); env != nullptr && *env != '\0') return env;
  return RIG_DDS_SECURITY_PLUGIN_DIR;
}

std::string security_plugin(const std::string& name) {
  const std::string dir = security_plugin_dir();
  const fs::path p = fs::path(dir) / ("libdds_security_" + name + ".so");
  if (dir.empty() || !fs::is_regular_file(p)) {
    throw std::runtime_error("DDS Security: Cyclone's plugin " + p.filename().string() + " not found in '" + dir +
                             "' (Debian: package libddsc0debian; or set RIG_DDS_SECURITY_PLUGINS to its directory)");
  }
  return p.string();
}

void set_security_properties(dds_qos_t* qos, const SecurityConfig& c) {
  struct Plugin {
    const char* name;
    const char* path_prop;
    const char* init_prop;
    const char* fini_prop;
    const char* init;
    const char* fini;
  };
  const std::vector<Plugin> plugins = {
      {"auth", "dds.sec.auth.library.path", "dds.sec.auth.library.init", "dds.sec.auth.library.finalize",
       "init_authentication", "finalize_authentication"},
      {"ac", "dds.sec.access.library.path", "dds.sec.access.library.init", "dds.sec.access.library.finalize",
       "init_access_control", "finalize_access_control"},
      {"crypto", "dds.sec.crypto.library.path", "dds.sec.crypto.library.init", "dds.sec.crypto.library.finalize",
       "init_crypto", "finalize_crypto"},
  };
  for (const auto& p : plugins) {
    dds_qset_prop(qos, p.path_prop, security_plugin(p.name).c_str());
    dds_qset_prop(qos, p.init_prop, p.init);
    dds_qset_prop(qos, p.fini_prop, p.fini);
  }
  // Cyclone takes URIs: file:PATH (absolute, so a child started elsewhere reads the same files).
  const auto uri = [](const std::string& f) { return "file:" + fs::absolute(f).string(); };
  dds_qset_prop(qos, "dds.sec.auth.identity_ca", uri(c.identity_ca).c_str());
  dds_qset_prop(qos, "dds.sec.auth.identity_certificate", uri(c.identity_certificate).c_str());
  dds_qset_prop(qos, "dds.sec.auth.private_key", uri(c.private_key).c_str());
  dds_qset_prop(qos, "dds.sec.access.permissions_ca", uri(c.permissions_ca).c_str());
  dds_qset_prop(qos, "dds.sec.access.governance", uri(c.governance).c_str());
  dds_qset_prop(qos, "dds.sec.access.permissions", uri(c.permissions).c_str());
  // Cyclone 0.10.2's own name for it (ORG_ECLIPSE_CYCLONEDDS_SEC_AUTH_CRL): the authentication
  // plugin checks this participant's certificate and every peer's against it.
  if (!c.crl.empty()) dds_qset_prop(qos, "org.eclipse.cyclonedds.sec.auth.crl", uri(c.crl).c_str());
}

}  // namespace sensor_rig::dds
