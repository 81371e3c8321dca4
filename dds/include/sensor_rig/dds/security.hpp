#pragma once
// DDS Security for one participant: the files of one identity (Cyclone's built-in plugins
// dds_security_auth / _ac / _crypto read them) and the directory `rig security init` writes.
//
// DIR/identity_ca.pem, DIR/permissions_ca.pem      the two CAs (certificates only)
// DIR/identity_crl.pem                             identities revoked (`rig security revoke`), signed by the identity CA
// DIR/governance.xml, DIR/governance.p7s           domain rules; .p7s = S/MIME signed by the permissions CA
// DIR/private/{identity,permissions}_ca_key.pem    the CA keys: needed only to add identities
// DIR/<identity>/cert.pem, key.pem                 the identity (signed by the identity CA)
// DIR/<identity>/permissions.xml, permissions.p7s  its grants; .p7s signed by the permissions CA
#include <ctime>
#include <string>

#include "sensor_rig/dds/driver_status.hpp"

namespace sensor_rig::dds {

struct SecurityConfig {
  std::string identity;  // a name for messages (the identity's directory name)
  std::string identity_ca, identity_certificate, private_key;
  std::string permissions_ca, governance, permissions;
  std::string crl;  // certificate revocation list of the identity CA
  [[nodiscard]] bool enabled() const { return !identity_certificate.empty(); }
};

// The files of `identity` in a `rig security init` directory. Throws std::runtime_error naming
// every missing file (and `rig security init` as the way to make them), a private key that group
// or others may read (its mode, and `chmod 600`), and a governance that lets a participant without
// credentials write /vehicle/dbw/cmd in Cyclone 0.10.2 (check_governance, security_init.hpp).
SecurityConfig security_files(const std::string& dir, const std::string& identity);

// RIG_DDS_SECURITY=DIR:IDENTITY in the environment: every participant of this process (and of the
// processes it starts) made without a SecurityConfig of its own authenticates as IDENTITY — how
// the whole rig runs secured (`rig security init --protect-writes`). Empty when unset; throws as
// security_files.
SecurityConfig security_from_environment();

// When the identity stops working: the earliest expiry of its certificate, its grant, the two CAs
// and the revocation list, and which one that is.
struct SecurityExpiry {
  std::time_t not_after = 0;
  std::string what;  // "certificate", "grant", "identity CA", "permissions CA", "revocation list"
};
SecurityExpiry security_expiry(const SecurityConfig& c);  // throws when a file does not parse
inline constexpr int kExpiryWarnDays = 30;
// Adds security_identity, security_expires (UTC, and what), security_days_left to a node's
// /diagnostics status; WARN from kExpiryWarnDays before, ERROR once expired (either replaces an OK).
void report_expiry(DriverStatus& d, const std::string& identity, const SecurityExpiry& e, std::time_t now);

// Where Cyclone's security plugins are looked for: $RIG_DDS_SECURITY_PLUGINS, else the directory
// found at build time (Debian: /usr/lib/<arch>/libddsc0debian, outside the loader's search path).
std::string security_plugin_dir();
// The plugin library `name` ("auth", "ac", "crypto") as a path; throws when it is not there.
std::string security_plugin(const std::string& name);

}  // namespace sensor_rig::dds
