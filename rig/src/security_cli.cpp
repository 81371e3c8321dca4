// `rig security init DIR`: the CAs, identities, governance and permissions of DDS Security for the
// drive-by-wire command topic (what they allow: dds/README.md "DDS Security"); `rig security
// add-identity DIR NAME`: one more identity signed by that directory's existing CAs; `rig security
// revoke DIR NAME`: withdraw one (the identity CA's revocation list).
#include <cstdio>
#include <ctime>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "rig_commands.hpp"
#include "sensor_rig/common/cli.hpp"
#include "sensor_rig/dds/security.hpp"
#include "sensor_rig/dds/security_init.hpp"

namespace sensor_rig::rig {

namespace {
std::string utc_day(std::time_t t) {
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[16];
  std::strftime(buf, sizeof buf, "%Y-%m-%d", &tm);
  return buf;
}

void register_revoke(CLI::App& sec, cli::Context& ctx) {
  auto dir = std::make_shared<std::string>();
  auto name = std::make_shared<std::string>();
  auto* rev = sec.add_subcommand("revoke",
                                 "withdraw identity NAME: its certificate goes on DIR/identity_crl.pem (signed by the "
                                 "identity CA); deploy that file to every host. Without NAME: re-sign the list as it is");
  rev->add_option("DIR", *dir, "a directory `rig security init` made, with private/")->required();
  rev->add_option("NAME", *name, "the identity to withdraw");
  rev->callback([dir, name, &ctx] {
    std::vector<std::string> files;
    try {
      files = dds::revoke_identity(*dir, *name);
    } catch (const std::runtime_error& e) {
      throw cli::UsageError(e.what());
    }
    for (const auto& f : files) std::printf("%s\n", f.c_str());
    if (name->empty()) {
      std::fprintf(stderr, "security revoke: revocation list of %s re-signed\n", dir->c_str());
    } else {
      std::fprintf(stderr, "security revoke: '%s' revoked; copy %s to every host running a secured node\n",
                   name->c_str(), files.front().c_str());
    }
    ctx.exit_code = cli::kOk;
  });
}

void register_add_identity(CLI::App& sec, cli::Context& ctx) {
  auto o = std::make_shared<dds::AddIdentityOptions>();
  auto permit_command = std::make_shared<bool>(false);
  auto* add = sec.add_subcommand("add-identity",
                                 "add identity NAME to DIR, signed by its existing CAs (DIR/private): identities "
                                 "already deployed stay valid; read-only unless --permit-command");
  add->add_option("DIR", o->dir, "a directory `rig security init` made")->required();
  add->add_option("NAME", o->name, "the new identity (DIR/NAME/: key, certificate, signed permissions)")->required();
  add->add_flag("--permit-command", *permit_command, "may publish /vehicle/dbw/cmd (a command source)");
  add->add_option("--days", o->days, "validity of its certificate and grant (never beyond the CAs')")
      ->check(CLI::Range(1, 36500))
      ->capture_default_str();
  add->callback([o, permit_command, &ctx] {
    o->role = *permit_command ? dds::Role::kCommander : dds::Role::kReader;
    std::vector<std::string> files;
    try {
      files = dds::add_identity(*o);
    } catch (const std::runtime_error& e) {
      throw cli::UsageError(e.what());
    }
    for (const auto& f : files) std::printf("%s\n", f.c_str());
    std::string validity;
    try {  // what a peer will accept: the earliest of the identity's and the CAs' expiry
      const auto expiry = dds::security_expiry(dds::security_files(o->dir, o->name));
      validity = ", valid until " + utc_day(expiry.not_after);
      if (expiry.not_after + 86400 < std::time(nullptr) + static_cast<std::time_t>(o->days) * 86400)
        validity += " (capped: " + expiry.what + " ends with its CA)";
    } catch (const std::runtime_error& e) {
      validity = " (not usable yet: " + std::string(e.what()) + ")";
    }
    std::fprintf(stderr, "security add-identity: '%s' (%s) in %s%s\n", o->name.c_str(),
                 *permit_command ? "may publish commands" : "read-only", o->dir.c_str(), validity.c_str());
    ctx.exit_code = cli::kOk;
  });
}
}  // namespace

void register_security_cli(CLI::App& app, cli::Context& ctx) {
  auto& sec = *app.add_subcommand("security", "DDS Security for /vehicle/dbw/cmd: keys and signed rules")
                   ->require_subcommand(1);
  auto o = std::make_shared<dds::SecurityInitOptions>();
  auto rsa = std::make_shared<bool>(false);
  auto no_unauth = std::make_shared<bool>(false);
  auto* init = sec.add_subcommand("init", "create CAs, identities (bridge, command sources, readers), governance "
                                          "and permissions (S/MIME) in DIR");
  init->add_option("DIR", o->dir, "directory to write (created)")->required();
  init->add_option("--bridge", o->bridge, "identity of the DBW bridge (subscribes commands)")->capture_default_str();
  init->add_option("--command", o->commanders, "identities allowed to publish commands (repeat)")
      ->capture_default_str();
  init->add_option("--reader", o->readers, "read-only identities (repeat)")->capture_default_str();
  init->add_flag("--rsa", *rsa, "RSA-2048 keys (default ECDSA P-256)");
  init->add_option("--days", o->days, "validity of the identities' certificates and grants (never beyond the CAs')")
      ->check(CLI::Range(1, 36500))
      ->capture_default_str();
  init->add_option("--ca-days", o->ca_days, "validity of the two CAs and the revocation list")
      ->check(CLI::Range(1, 36500))
      ->capture_default_str();
  init->add_option("--organization", o->organization, "O= of every certificate")->capture_default_str();
  init->add_flag("--no-unauthenticated", *no_unauth,
                 "governance without allow_unauthenticated_participants: ordinary ROS 2 nodes see nothing");
  init->add_flag("--force", o->force, "replace an earlier init in DIR");
  auto writes = std::make_shared<std::string>("none");
  init->add_option("--protect-writes", *writes,
                   "write access control on rt/vehicle/*, rt/sensors/*, rt/rig/*: access (reads stay open; strict "
                   "readers refuse ungranted writers) or sign (every reader and writer must be authenticated)")
      ->check(CLI::IsMember({"none", "access", "sign"}))
      ->capture_default_str();
  init->add_option("--node", o->nodes, "identities of the rig's nodes, may publish its topics (with --protect-writes; "
                                       "default rig_node; RIG_DDS_SECURITY=DIR:NAME runs a process as one)");
  init->add_option("--strict-reader", o->strict_readers,
                   "read-only identities that take the rig's topics only from granted writers (repeat)");
  auto protection = std::make_shared<std::string>("sign-origin");
  init->add_option("--cmd-protection", *protection,
                   "submessage protection of /vehicle/dbw/cmd (dds/README.md: what each costs)")
      ->check(CLI::IsMember({"none", "sign", "encrypt", "sign-origin", "encrypt-origin"}))  // none: --no-unauthenticated
      ->capture_default_str();
  init->callback([o, rsa, no_unauth, protection, writes, &ctx] {
    const std::map<std::string, dds::WriteProtection> write_kinds{{"none", dds::WriteProtection::kNone},
                                                                  {"access", dds::WriteProtection::kAccess},
                                                                  {"sign", dds::WriteProtection::kSign}};
    o->protect_writes = write_kinds.at(*writes);
    const std::map<std::string, dds::Protection> kinds{{"none", dds::Protection::kNone},
                                                       {"sign", dds::Protection::kSign},
                                                       {"encrypt", dds::Protection::kEncrypt},
                                                       {"sign-origin", dds::Protection::kSignOrigin},
                                                       {"encrypt-origin", dds::Protection::kEncryptOrigin}};
    o->command_protection = kinds.at(*protection);
    o->key_type = *rsa ? dds::KeyType::kRsa2048 : dds::KeyType::kEcP256;
    o->allow_unauthenticated = !*no_unauth;
    std::vector<std::string> files;
    try {
      files = dds::init_security_dir(*o);
    } catch (const std::runtime_error& e) {
      throw cli::UsageError(e.what());
    }
    for (const auto& f : files) std::printf("%s\n", f.c_str());
    std::fprintf(stderr, "security init: %zu files in %s (keep private/ off the car)\n", files.size(), o->dir.c_str());
    ctx.exit_code = cli::kOk;
  });
  register_add_identity(sec, ctx);
  register_revoke(sec, ctx);
}

}  // namespace sensor_rig::rig
