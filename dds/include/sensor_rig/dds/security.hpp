#pragma once
// DDS Security for one participant: the files of one identity (Cyclone's built-in plugins
// dds_security_auth / _ac / _crypto read them) and the directory `rig security init` writes.
//
// DIR/identity_ca.pem, DIR/permissions_ca.pem      the two CAs (certificates only)
// DIR/governance.xml, DIR/governance.p7s           domain rules; .p7s = S/MIME signed by the permissions CA
// DIR/private/{identity,permissions}_ca_key.pem    the CA keys: needed only to add identities
// DIR/<identity>/cert.pem, key.pem                 the identity (signed by the identity CA)
// DIR/<identity>/permissions.xml, permissions.p7s  its grants; .p7s signed by the permissions CA
#include <string>

namespace sensor_rig::dds {

struct SecurityConfig {
  std::string identity;  // a name for messages (the identity's directory name)
  std::string identity_ca, identity_certificate, private_key;
  std::string permissions_ca, governance, permissions;
  [[nodiscard]] bool enabled() const { return !identity_certificate.empty(); }
};

// The files of `identity` in a `rig security init` directory. Throws std::runtime_error naming
// every missing file (and `rig security init` as the way to make them).
SecurityConfig security_files(const std::string& dir, const std::string& identity);

// Where Cyclone's security plugins are looked for: $RIG_DDS_SECURITY_PLUGINS, else the directory
// found at build time (Debian: /usr/lib/<arch>/libddsc0debian, outside the loader's search path).
std::string security_plugin_dir();
// The plugin library `name` ("auth", "ac", "crypto") as a path; throws when it is not there.
std::string security_plugin(const std::string& name);

}  // namespace sensor_rig::dds
