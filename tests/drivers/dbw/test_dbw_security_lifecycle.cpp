// Issue 28, without processes: what `rig security init` refuses to make (a command protection
// Cyclone 0.10.2 cannot enforce), how it writes keys (0600, atomically, never through a symlink;
// folders 0700), what a participant refuses to load (a key others may read, an unenforceable
// governance), revocation (the identity CA's CRL, checked here with OpenSSL as Cyclone's plugin
// checks it), validity capped by the CAs, and expiry in /diagnostics.
#include <gtest/gtest.h>
#include <openssl/x509_vfy.h>
#include <unistd.h>

#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "security_test_support.hpp"
#include "sensor_rig/dds/security.hpp"
#include "sensor_rig/dds/security_init.hpp"

namespace fs = std::filesystem;
namespace dds = sensor_rig::dds;
using dds::test::Dir;
using dds::test::mode_of;
using dds::test::read;

namespace {

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "no error";
}

dds::SecurityInitOptions small_init(const Dir& d) {
  dds::SecurityInitOptions o;
  o.dir = (d.path / "sec").string();
  return o;
}

// X509_verify_cert of DIR/NAME/cert.pem against the identity CA and DIR's CRL, as Cyclone's
// authentication plugin does (auth_utils.c verify_certificate): X509_V_OK or the error.
int verify_with_crl(const fs::path& dir, const std::string& name) {
  const auto ca = dds::test::load_cert(dir / "identity_ca.pem");
  const auto cert = dds::test::load_cert(dir / name / "cert.pem");
  std::unique_ptr<BIO, decltype(&BIO_free)> b(BIO_new_file((dir / "identity_crl.pem").c_str(), "r"), &BIO_free);
  std::unique_ptr<X509_CRL, decltype(&X509_CRL_free)> crl(
      b ? PEM_read_bio_X509_CRL(b.get(), nullptr, nullptr, nullptr) : nullptr, &X509_CRL_free);
  if (!ca || !cert || !crl) return -1;
  std::unique_ptr<X509_STORE, decltype(&X509_STORE_free)> store(X509_STORE_new(), &X509_STORE_free);
  X509_STORE_add_cert(store.get(), ca.get());
  X509_STORE_add_crl(store.get(), crl.get());
  std::unique_ptr<X509_STORE_CTX, decltype(&X509_STORE_CTX_free)> ctx(X509_STORE_CTX_new(), &X509_STORE_CTX_free);
  X509_STORE_CTX_init(ctx.get(), store.get(), cert.get(), nullptr);
  X509_STORE_CTX_set_flags(ctx.get(), X509_V_FLAG_CRL_CHECK);
  return X509_verify_cert(ctx.get()) == 1 ? X509_V_OK : X509_STORE_CTX_get_error(ctx.get());
}

TEST(SecurityIssue28, NoneOnlyWithoutUnauthenticatedParticipants) {
  Dir d;
  auto o = small_init(d);
  o.command_protection = dds::Protection::kNone;
  EXPECT_NE(error_of([&] { dds::init_security_dir(o); }).find("would let any participant without credentials drive"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(d.path / "sec/identity_ca.pem")) << "wrote files for a refused combination";
  o.allow_unauthenticated = false;
  EXPECT_NO_THROW(dds::init_security_dir(o));
  EXPECT_NO_THROW(dds::security_files(o.dir, "dbw_command"));
  for (const auto p : {dds::Protection::kSign, dds::Protection::kEncrypt, dds::Protection::kSignOrigin,
                       dds::Protection::kEncryptOrigin}) {
    EXPECT_NO_THROW(dds::check_governance(dds::governance_xml(true, p), "g")) << dds::to_governance_word(p);
  }
  EXPECT_NO_THROW(dds::check_governance(dds::governance_xml(false, dds::Protection::kNone), "g"));
  const std::string bad = dds::governance_xml(true, dds::Protection::kNone);
  EXPECT_NE(error_of([&] { dds::check_governance(bad, "g.p7s"); }).find("g.p7s lets a participant without credentials"),
            std::string::npos);
  // The first matching rule counts: a `*` rule without write access control put before the command's.
  std::string star_first = dds::governance_xml(true, dds::Protection::kSignOrigin);
  const auto rules = star_first.find("<topic_rule>");
  const auto star = star_first.rfind("<topic_rule>");
  const auto star_end = star_first.find("</topic_rule>", star) + std::string("</topic_rule>").size();
  const std::string star_rule = star_first.substr(star, star_end - star);
  star_first.erase(star, star_end - star);
  star_first.insert(rules, star_rule);
  EXPECT_NE(error_of([&] { dds::check_governance(star_first, "g"); }).find("no write access control"),
            std::string::npos);

  // A directory an older `rig` made with none and unauthenticated participants: refused at load.
  Dir d2;
  auto o2 = small_init(d2);
  dds::init_security_dir(o2);
  std::string p7s = read(d2.path / "sec/governance.p7s");
  const std::string kind = "<metadata_protection_kind>SIGN_WITH_ORIGIN_AUTHENTICATION";
  p7s.replace(p7s.find(kind), kind.size(), "<metadata_protection_kind>NONE");
  std::ofstream(d2.path / "sec/governance.p7s", std::ios::trunc) << p7s;
  EXPECT_NE(error_of([&] { dds::security_files(o2.dir, "dbw_bridge"); }).find("lets a participant without credentials"),
            std::string::npos);
}

TEST(SecurityIssue28, KeysPrivateFoldersPrivateReplacedNotWrittenThrough) {
  Dir d;
  auto o = small_init(d);
  dds::init_security_dir(o);
  const fs::path s = o.dir;
  EXPECT_EQ(mode_of(s), 0700U);
  EXPECT_EQ(mode_of(s / "private"), 0700U);
  for (const std::string id : {"dbw_bridge", "dbw_command", "reader"}) {
    EXPECT_EQ(mode_of(s / id), 0700U) << id;
    EXPECT_EQ(mode_of(s / id / "key.pem"), 0600U) << id;
  }
  EXPECT_EQ(mode_of(s / "private/identity_ca_key.pem"), 0600U);

  // What --force found: a key left 0644, a key that is a symlink to someone else's file, an
  // identity folder 0755.
  fs::permissions(s / "dbw_command/key.pem", fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read |
                                                 fs::perms::others_read);
  const fs::path victim = d.path / "victim.txt";
  std::ofstream(victim) << "not a key";
  fs::remove(s / "reader/key.pem");
  fs::create_symlink(victim, s / "reader/key.pem");
  fs::permissions(s / "dbw_bridge", fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                        fs::perms::others_read | fs::perms::others_exec);
  o.force = true;
  dds::init_security_dir(o);
  EXPECT_EQ(mode_of(s / "dbw_command/key.pem"), 0600U);
  EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(s / "reader/key.pem"))) << "the symlink was written through";
  EXPECT_EQ(read(victim), "not a key");
  EXPECT_EQ(mode_of(s / "dbw_bridge"), 0700U);
  for (const auto& e : fs::directory_iterator(s / "dbw_command"))
    EXPECT_EQ(e.path().filename().string().rfind(".", 0), std::string::npos) << "temporary left: " << e.path();

  // An identity folder that is a symlink: refused, nothing written where it points.
  fs::remove_all(s / "reader");
  fs::create_directories(d.path / "elsewhere");
  fs::create_directory_symlink(d.path / "elsewhere", s / "reader");
  EXPECT_NE(error_of([&] { dds::init_security_dir(o); }).find("is a symlink"), std::string::npos);
  EXPECT_TRUE(fs::is_empty(d.path / "elsewhere"));
}

TEST(SecurityIssue28, KeyReadableByOthersRefusedAtLoad) {
  Dir d;
  auto o = small_init(d);
  dds::init_security_dir(o);
  const fs::path key = fs::path(o.dir) / "dbw_command/key.pem";
  for (const unsigned mode : {0644U, 0640U, 0604U, 0660U}) {
    ::chmod(key.c_str(), mode);
    const std::string e = error_of([&] { dds::security_files(o.dir, "dbw_command"); });
    EXPECT_NE(e.find("private key of identity 'dbw_command'"), std::string::npos) << e;
    EXPECT_NE(e.find("chmod 600"), std::string::npos) << e;
    char m[8];
    std::snprintf(m, sizeof m, "%04o", mode);
    EXPECT_NE(e.find(std::string("mode ") + m), std::string::npos) << e;
  }
  ::chmod(key.c_str(), 0400);
  EXPECT_NO_THROW(dds::security_files(o.dir, "dbw_command"));
}

TEST(SecurityIssue28, RevokePutsTheCertificateOnTheIdentityCasList) {
  Dir d;
  auto o = small_init(d);
  dds::init_security_dir(o);
  const fs::path s = o.dir;
  EXPECT_EQ(verify_with_crl(s, "dbw_command"), X509_V_OK) << "the empty list after init";
  EXPECT_EQ(dds::security_files(o.dir, "dbw_command").crl, (s / "identity_crl.pem").string());
  EXPECT_EQ(dds::revoke_identity(o.dir, "dbw_command"), std::vector<std::string>{(s / "identity_crl.pem").string()});
  EXPECT_EQ(verify_with_crl(s, "dbw_command"), X509_V_ERR_CERT_REVOKED);
  EXPECT_EQ(verify_with_crl(s, "dbw_bridge"), X509_V_OK);
  dds::revoke_identity(o.dir, "reader");  // a second one keeps the first
  EXPECT_EQ(verify_with_crl(s, "dbw_command"), X509_V_ERR_CERT_REVOKED);
  EXPECT_EQ(verify_with_crl(s, "reader"), X509_V_ERR_CERT_REVOKED);
  EXPECT_NE(error_of([&] { dds::revoke_identity(o.dir, "reader"); }).find("already revoked"), std::string::npos);
  EXPECT_NE(error_of([&] { dds::revoke_identity(o.dir, "nobody"); }).find("no identity 'nobody'"), std::string::npos);
  // The list lasts as long as the identity CA (an expired CRL fails every certificate).
  const std::string first = dds::security_expiry(dds::security_files(o.dir, "dbw_bridge")).what;
  EXPECT_TRUE(first == "certificate" || first == "grant") << first << " expires before the identity";
  // A directory without the list (made before it existed): refused at load, `revoke DIR` makes it.
  fs::remove(s / "identity_crl.pem");
  EXPECT_NE(error_of([&] { dds::security_files(o.dir, "dbw_bridge"); }).find("identity_crl.pem"), std::string::npos);
  dds::revoke_identity(o.dir, "");
  EXPECT_EQ(verify_with_crl(s, "dbw_command"), X509_V_OK);
  fs::remove_all(s / "private");
  EXPECT_NE(error_of([&] { dds::revoke_identity(o.dir, "dbw_bridge"); }).find("has no private/identity_ca_key.pem"),
            std::string::npos);
}

TEST(SecurityIssue28, ValidityCappedByTheCasAndShorterByDefault) {
  Dir d;
  auto o = small_init(d);
  EXPECT_EQ(o.days, 365);
  o.ca_days = 100;
  o.days = 400;
  dds::init_security_dir(o);
  const fs::path s = o.dir;
  const std::time_t ca_end = dds::test::not_after(s / "identity_ca.pem");
  EXPECT_LE(dds::test::not_after(s / "dbw_command/cert.pem"), ca_end);
  dds::AddIdentityOptions a;
  a.dir = o.dir;
  a.name = "planner";
  a.role = dds::Role::kCommander;
  a.days = 36500;
  dds::add_identity(a);
  EXPECT_LE(dds::test::not_after(s / "planner/cert.pem"), ca_end);
  const auto e = dds::security_expiry(dds::security_files(o.dir, "planner"));
  EXPECT_LE(e.not_after, ca_end);
  EXPECT_GT(e.not_after, std::time(nullptr) + 98L * 86400);
  const std::string grant = read(s / "planner/permissions.xml");
  EXPECT_NE(grant.find("<not_after>"), std::string::npos);
  a.name = "short";
  a.days = 7;
  dds::add_identity(a);
  const auto short_e = dds::security_expiry(dds::security_files(o.dir, "short"));
  EXPECT_LE(short_e.not_after, std::time(nullptr) + 7L * 86400 + 60);
}

// --protect-writes: the rig's topics under write access control, a node identity that may publish
// them but never commands, and strict readers with a governance of their own (picked at load).
TEST(SecurityIssue28, WriteProtectionRulesNodeGrantAndStrictReaders) {
  Dir d;
  auto o = small_init(d);
  o.protect_writes = dds::WriteProtection::kAccess;
  o.strict_readers = {"planner"};
  dds::init_security_dir(o);
  const fs::path s = o.dir;
  const std::string gov = read(s / "governance.xml");
  for (const std::string expr : {"rt/vehicle/*", "rt/sensors/*", "rt/rig/*"}) {
    const auto at = gov.find("<topic_expression>" + expr + "</topic_expression>");
    ASSERT_NE(at, std::string::npos) << expr;
    const std::string rule = gov.substr(at, gov.find("</topic_rule>", at) - at);
    EXPECT_NE(rule.find("<enable_write_access_control>true"), std::string::npos) << expr;
    EXPECT_NE(rule.find("<enable_read_access_control>false"), std::string::npos) << expr;
    EXPECT_NE(rule.find("<metadata_protection_kind>NONE"), std::string::npos) << expr;
  }
  // The command rule still comes first (first match wins) and the loader accepts it.
  EXPECT_LT(gov.find("rt/vehicle/dbw/cmd"), gov.find("rt/vehicle/*"));
  EXPECT_NO_THROW(dds::check_governance(gov, "g"));
  const std::string node = read(s / "rig_node/permissions.xml");
  const std::string publish = node.substr(node.find("<publish>"), node.find("</publish>") - node.find("<publish>"));
  EXPECT_NE(publish.find("<topic>rt/sensors/*</topic>"), std::string::npos) << publish;
  EXPECT_EQ(publish.find("rt/vehicle/*"), std::string::npos) << "a wildcard over the command topic: " << publish;
  EXPECT_EQ(publish.find("dbw/cmd"), std::string::npos) << publish;
  EXPECT_EQ(dds::security_files(o.dir, "planner").governance, (s / "planner/governance.p7s").string());
  EXPECT_NE(read(s / "planner/governance.xml").find("<allow_unauthenticated_participants>false"), std::string::npos);
  EXPECT_EQ(dds::security_files(o.dir, "reader").governance, (s / "governance.p7s").string());
  // --force without the strict reader: its old governance goes with it.
  o.force = true;
  o.strict_readers.clear();
  o.readers = {"reader", "planner"};
  o.protect_writes = dds::WriteProtection::kSign;
  dds::init_security_dir(o);
  EXPECT_FALSE(fs::exists(s / "planner/governance.p7s"));
  EXPECT_NE(read(s / "governance.xml").find("<metadata_protection_kind>SIGN</metadata_protection_kind>"),
            std::string::npos);
}

TEST(SecurityIssue28, ExpiryInDiagnosticsWarns30DaysAhead) {
  dds::SecurityExpiry e{1'900'000'000, "certificate"};
  const auto status = [&](std::time_t now) {
    dds::DriverStatus d;
    d.message = "ENGAGED";
    dds::report_expiry(d, "dbw_bridge", e, now);
    return d;
  };
  const auto value = [](const dds::DriverStatus& d, const std::string& k) {
    for (const auto& [key, v] : d.values)
      if (key == k) return v;
    return std::string("absent");
  };
  auto d = status(e.not_after - 31L * 86400);
  EXPECT_EQ(d.level, dds::Level::kOk);
  EXPECT_EQ(value(d, "security_identity"), "dbw_bridge");
  EXPECT_EQ(value(d, "security_expires"), "2030-03-17T17:46:40Z (certificate)");
  EXPECT_EQ(value(d, "security_days_left"), "31");
  d = status(e.not_after - 29L * 86400);
  EXPECT_EQ(d.level, dds::Level::kWarn);
  EXPECT_NE(d.message.find("certificate of 'dbw_bridge' expires 2030-03-17"), std::string::npos) << d.message;
  d = status(e.not_after + 1);
  EXPECT_EQ(d.level, dds::Level::kError);
  EXPECT_NE(d.message.find("expired"), std::string::npos) << d.message;
}

}  // namespace
