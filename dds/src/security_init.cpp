// `rig security init DIR`: CAs, identities, governance and permissions (layout: security.hpp).
#include <algorithm>
#include <ctime>
#include <filesystem>
#include <set>
#include <stdexcept>

#include "sensor_rig/dds/security_init.hpp"
#include "x509.hpp"

namespace sensor_rig::dds {
namespace fs = std::filesystem;
namespace {

// A name that is a directory name, a certificate CN and an XML grant name without escaping.
void check_name(const std::string& n) {
  const bool ok = !n.empty() && n.size() <= 64 && n.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                                                       "0123456789_-") == std::string::npos;
  if (!ok || n == "private") {
    throw std::runtime_error("identity name '" + n + "': use 1-64 letters, digits, '_' or '-' (not 'private')");
  }
}

void write_text(const std::string& path, const std::string& text) { x509::write_file(path, text, 0644); }

// A folder of ours, 0700 (identities' keys, the CA keys): made if missing, never a symlink (we would
// write the keys wherever it points).
void private_dir(const fs::path& d) {
  if (fs::is_symlink(d)) throw std::runtime_error("'" + d.string() + "' is a symlink; refusing to write keys into it");
  fs::create_directories(d);
  fs::permissions(d, fs::perms::owner_all, fs::perm_options::replace);
}

std::time_t days_from_now(int days) { return std::time(nullptr) + static_cast<std::time_t>(days) * 86400; }

// The signers of a directory: identity CA and permissions CA, each with its key.
struct Authorities {
  x509::Cert id_ca;
  x509::Key id_ca_key;
  x509::Cert perm_ca;
  x509::Key perm_ca_key;
};

// DIR/<name>/: key and certificate (signed by the identity CA), grants (signed by the permissions CA),
// valid for `days` but never beyond either CA (a peer would refuse the identity then anyway).
void write_identity(const fs::path& dir, const std::string& name, Role role, const std::string& organization,
                    KeyType key_type, int days, const Authorities& ca, std::vector<std::string>& written) {
  const auto out = [&](const fs::path& p) { return written.emplace_back(p.string()); };
  const fs::path d = dir / name;
  private_dir(d);
  const std::time_t not_after = std::min({days_from_now(days), x509::not_after_of(ca.id_ca.get()),
                                          x509::not_after_of(ca.perm_ca.get())});
  const auto key = x509::make_key(key_type);
  const auto cert =
      x509::make_cert(name, organization, key.get(), ca.id_ca.get(), ca.id_ca_key.get(), not_after, false);
  x509::write_cert(out(d / "cert.pem"), cert.get());
  x509::write_key(out(d / "key.pem"), key.get());
  const std::string perms = permissions_xml(name, identity_subject(name, organization), role, not_after);
  write_text(out(d / "permissions.xml"), perms);
  x509::write_smime(out(d / "permissions.p7s"), perms, ca.perm_ca.get(), ca.perm_ca_key.get());
}
}  // namespace

std::vector<std::string> init_security_dir(const SecurityInitOptions& o) {
  if (o.dir.empty()) throw std::runtime_error("security init: no directory given");
  if (o.days < 1 || o.days > 36500) throw std::runtime_error("security init: --days must be 1..36500");
  if (o.ca_days < 1 || o.ca_days > 36500) throw std::runtime_error("security init: --ca-days must be 1..36500");
  if (o.command_protection == Protection::kNone && o.allow_unauthenticated) {
    throw std::runtime_error(
        "security init: --cmd-protection none with unauthenticated participants allowed would let any participant "
        "without credentials drive: Cyclone 0.10.2 matches their writers with a topic that has no submessage "
        "protection without asking access control. Use sign, encrypt, sign-origin or encrypt-origin, or add "
        "--no-unauthenticated (then ordinary ROS 2 nodes see none of the secured nodes' topics)");
  }
  if (o.organization.empty() || o.organization.find_first_of(",=+<>#;\"\\") != std::string::npos)
    throw std::runtime_error("security init: organization '" + o.organization + "' must be plain text");
  std::vector<std::pair<std::string, Role>> ids{{o.bridge, Role::kBridge}};
  for (const auto& n : o.commanders) ids.emplace_back(n, Role::kCommander);
  for (const auto& n : o.readers) ids.emplace_back(n, Role::kReader);
  for (const auto& n : o.strict_readers) ids.emplace_back(n, Role::kReader);
  std::vector<std::string> nodes = o.nodes;
  if (o.protect_writes != WriteProtection::kNone && nodes.empty()) nodes.emplace_back("rig_node");
  for (const auto& n : nodes) ids.emplace_back(n, Role::kNode);
  std::set<std::string> seen;
  for (const auto& [name, role] : ids) {
    check_name(name);
    if (!seen.insert(name).second) throw std::runtime_error("security init: identity '" + name + "' named twice");
  }
  const fs::path dir(o.dir);
  if (fs::exists(dir / "identity_ca.pem") && !o.force) {
    throw std::runtime_error("security init: '" + o.dir +
                             "' already holds a CA (identity_ca.pem); --force replaces everything in it");
  }
  if (!fs::exists(dir)) private_dir(dir);  // a folder given to us keeps its mode
  private_dir(dir / "private");
  std::vector<std::string> written;
  const auto out = [&](const fs::path& p) { return written.emplace_back(p.string()); };

  // Two CAs: who a node is (identity) and what it may do (permissions) are signed separately, so
  // the permissions key can stay with whoever decides grants.
  Authorities ca;
  ca.id_ca_key = x509::make_key(o.key_type);
  const std::time_t ca_not_after = days_from_now(o.ca_days);
  ca.id_ca = x509::make_cert("sensor-rig identity CA", o.organization, ca.id_ca_key.get(), nullptr, nullptr,
                             ca_not_after, true);
  ca.perm_ca_key = x509::make_key(o.key_type);
  ca.perm_ca = x509::make_cert("sensor-rig permissions CA", o.organization, ca.perm_ca_key.get(), nullptr, nullptr,
                               ca_not_after, true);
  x509::write_cert(out(dir / "identity_ca.pem"), ca.id_ca.get());
  x509::write_key(out(dir / "private/identity_ca_key.pem"), ca.id_ca_key.get());
  x509::write_cert(out(dir / "permissions_ca.pem"), ca.perm_ca.get());
  x509::write_key(out(dir / "private/permissions_ca_key.pem"), ca.perm_ca_key.get());
  // Nobody revoked yet; Cyclone wants the list from the start (CRL check on every certificate).
  const auto crl = x509::make_crl(ca.id_ca.get(), ca.id_ca_key.get(), {}, ca_not_after);
  x509::write_crl(out(dir / "identity_crl.pem"), crl.get());

  const std::string governance = governance_xml(o.allow_unauthenticated, o.command_protection, o.protect_writes);
  write_text(out(dir / "governance.xml"), governance);
  x509::write_smime(out(dir / "governance.p7s"), governance, ca.perm_ca.get(), ca.perm_ca_key.get());

  for (const auto& [name, role] : ids) {
    write_identity(dir, name, role, o.organization, o.key_type, o.days, ca, written);
    fs::remove(dir / name / "governance.p7s");  // a strict reader's, from an earlier init (--force)
    fs::remove(dir / name / "governance.xml");
  }
  // A strict reader's own governance: the same rules, unauthenticated participants ignored.
  const std::string strict = governance_xml(false, o.command_protection, o.protect_writes);
  for (const auto& n : o.strict_readers) {
    write_text(out(dir / n / "governance.xml"), strict);
    x509::write_smime(out(dir / n / "governance.p7s"), strict, ca.perm_ca.get(), ca.perm_ca_key.get());
  }
  return written;
}

std::vector<std::string> add_identity(const AddIdentityOptions& o) {
  if (o.dir.empty()) throw std::runtime_error("security add-identity: no directory given");
  if (o.days < 1 || o.days > 36500) throw std::runtime_error("security add-identity: --days must be 1..36500");
  check_name(o.name);
  const fs::path dir(o.dir);
  std::string missing;
  for (const char* f : {"identity_ca.pem", "permissions_ca.pem", "private/identity_ca_key.pem",
                        "private/permissions_ca_key.pem"}) {
    if (!fs::is_regular_file(dir / f)) missing += std::string(missing.empty() ? "" : ", ") + f;
  }
  if (!missing.empty()) {
    throw std::runtime_error("security add-identity: '" + o.dir + "' holds no complete CA (missing " + missing +
                             "); `rig security init DIR` makes one");
  }
  if (fs::exists(dir / o.name)) {
    throw std::runtime_error("security add-identity: identity '" + o.name + "' already exists in '" + o.dir +
                             "' (it may be deployed: choose another name, or remove " + (dir / o.name).string() +
                             " first)");
  }
  Authorities ca{x509::read_cert((dir / "identity_ca.pem").string()),
                 x509::read_key((dir / "private/identity_ca_key.pem").string()),
                 x509::read_cert((dir / "permissions_ca.pem").string()),
                 x509::read_key((dir / "private/permissions_ca_key.pem").string())};
  if (X509_check_private_key(ca.id_ca.get(), ca.id_ca_key.get()) != 1 ||
      X509_check_private_key(ca.perm_ca.get(), ca.perm_ca_key.get()) != 1) {
    throw std::runtime_error("security add-identity: the keys in '" + (dir / "private").string() +
                             "' are not those of identity_ca.pem / permissions_ca.pem");
  }
  std::vector<std::string> written;
  write_identity(dir, o.name, o.role, x509::organization_of(ca.id_ca.get()), x509::key_type_of(ca.id_ca_key.get()),
                 o.days, ca, written);
  return written;
}

}  // namespace sensor_rig::dds
