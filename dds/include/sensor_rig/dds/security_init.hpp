#pragma once
// `rig security init DIR`: two CAs (identities, permissions), one identity per node, the domain's
// governance and each identity's permissions, S/MIME-signed as DDS Security requires. Layout in
// security.hpp. What the governance protects and why: dds/README.md "DDS Security".
#include <ctime>
#include <string>
#include <vector>

namespace sensor_rig::dds {

// The DDS topic the rules protect (ROS 2 /vehicle/dbw/cmd).
inline constexpr const char* kProtectedCommandTopic = "rt/vehicle/dbw/cmd";

enum class KeyType { kEcP256, kRsa2048 };  // what Cyclone's auth plugin accepts

// metadata_protection_kind of the command topic (its submessages): none (access control only),
// sign / encrypt (one key per writer), *-origin (plus a MAC per receiver). Default sign-origin.
// kNone only with allow_unauthenticated false: Cyclone 0.10.2 matches a writer of an
// unauthenticated participant with a reader whose topic has neither submessage nor payload
// protection without asking access control (ddsi_security_omg.c, check_remote_writer_permissions).
enum class Protection { kNone, kSign, kEncrypt, kSignOrigin, kEncryptOrigin };
std::string to_governance_word(Protection p);  // NONE, SIGN, ..., SIGN_WITH_ORIGIN_AUTHENTICATION

// Write protection of rt/vehicle/*, rt/sensors/*, rt/rig/* (issue 28; dds/README.md has the costs):
// kAccess: write access control only (reads stay open to ordinary nodes; a writer without
// credentials is refused only by strict readers), kSign: also signed submessages (every writer and
// every reader must be authenticated).
enum class WriteProtection { kNone, kAccess, kSign };

struct SecurityInitOptions {
  std::string dir;
  std::string bridge = "dbw_bridge";                   // subscribes commands, publishes status/state
  std::vector<std::string> commanders = {"dbw_command"};  // may publish commands
  std::vector<std::string> readers = {"reader"};          // may subscribe to everything, publish nothing
  // Readers with a governance of their own (NAME/governance.p7s) without unauthenticated
  // participants: they take rt/vehicle/*, rt/sensors/*, rt/rig/* only from granted writers.
  std::vector<std::string> strict_readers;
  WriteProtection protect_writes = WriteProtection::kNone;
  std::vector<std::string> nodes;  // may publish the rig's own topics (with protect_writes; default rig_node)
  KeyType key_type = KeyType::kEcP256;
  int days = 365;                     // validity of the identities' certificates and grants
  int ca_days = 3650;                 // validity of the two CAs (identities never outlive them)
  bool allow_unauthenticated = true;  // ordinary (unsecured) ROS 2 nodes still read the sensor topics
  Protection command_protection = Protection::kSignOrigin;
  std::string organization = "sensor-rig";
  bool force = false;  // replace what an earlier init wrote (else: refuse)
};

// Writes the directory (folders 0700, keys 0600, every file replaced atomically, never through a
// symlink) and an empty revocation list; returns the files written. Throws std::runtime_error (bad
// names, a protection kind Cyclone cannot enforce with these options, a directory already
// initialised without force, OpenSSL failures with its error text).
std::vector<std::string> init_security_dir(const SecurityInitOptions& o);

// The governance and permissions documents (unsigned XML), for init and for the tests.
std::string governance_xml(bool allow_unauthenticated, Protection command_protection = Protection::kSignOrigin,
                           WriteProtection writes = WriteProtection::kNone);
enum class Role { kBridge, kCommander, kReader, kNode };
std::string permissions_xml(const std::string& identity, const std::string& subject, Role role,
                            std::time_t not_after);
// Throws std::runtime_error when Cyclone 0.10.2 would let a participant without credentials write
// the command topic under this (signed or plain) governance: allow_unauthenticated_participants
// with a command rule (the first whose expression matches it) without write access control, or
// with neither metadata nor data protection. `where` names the file in the message.
void check_governance(const std::string& governance, const std::string& where);
// The subject of an identity's certificate, as the grant names it (RFC 2253: "CN=x,O=y").
std::string identity_subject(const std::string& identity, const std::string& organization);

// `rig security add-identity DIR NAME`: one more identity in an initialised directory, signed by
// its existing CAs (DIR/private/*_ca_key.pem), so every identity already deployed stays valid.
// Its key type and organization follow the identity CA's; its own permissions are signed by the
// permissions CA (grants are per identity: no other file changes).
struct AddIdentityOptions {
  std::string dir;
  std::string name;
  Role role = Role::kReader;  // kCommander: may publish /vehicle/dbw/cmd
  int days = 365;             // capped by the identity and permissions CAs' own expiry
};
// Returns the files written. Throws std::runtime_error: no CA in DIR (or its keys missing or not
// its keys), a bad name, an identity of that name already there, OpenSSL failures.
std::vector<std::string> add_identity(const AddIdentityOptions& o);

// `rig security revoke DIR NAME`: adds NAME's certificate to DIR/identity_crl.pem, re-signed by
// the identity CA (valid until the CA expires). Every participant given that CRL (Cyclone's
// org.eclipse.cyclonedds.sec.auth.crl) refuses NAME in the handshake; deploy the CRL to every
// host. An empty name re-signs the list as it is (an empty one where there was none). Returns the
// files written; throws std::runtime_error: no CA key, no such identity, already revoked.
std::vector<std::string> revoke_identity(const std::string& dir, const std::string& name);

}  // namespace sensor_rig::dds
