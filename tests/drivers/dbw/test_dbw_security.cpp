// Issue 13: what `rig security init` writes, checked with OpenSSL directly (not through the code
// that wrote it): certificates verify against the identity CA only; governance and permissions are
// S/MIME signed by the permissions CA, their signed content is the XML beside them, and a changed
// byte breaks the signature; each grant names its certificate's subject and what the role may do;
// keys are private. And the rig config's `dbw.security` section (file:line:col problems).
#include <gtest/gtest.h>
#include <openssl/pem.h>
#include <openssl/pkcs7.h>
#include <openssl/x509.h>
#include <openssl/x509_vfy.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "sensor_rig/common/config_node.hpp"
#include "sensor_rig/dds/security_init.hpp"
#include "sensor_rig/drivers/dbw/dbw_config.hpp"

namespace fs = std::filesystem;
namespace dds = sensor_rig::dds;
namespace config = sensor_rig::config;

namespace {

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

struct Dir {
  Dir() {
    char tmpl[] = "/tmp/rig_security_XXXXXX";
    path = ::mkdtemp(tmpl);
  }
  ~Dir() { fs::remove_all(path); }
  Dir(const Dir&) = delete;
  Dir& operator=(const Dir&) = delete;
  fs::path path;
};

using CertPtr = std::unique_ptr<X509, decltype(&X509_free)>;
CertPtr load_cert(const fs::path& p) {
  std::unique_ptr<BIO, decltype(&BIO_free)> b(BIO_new_file(p.c_str(), "r"), &BIO_free);
  return {b ? PEM_read_bio_X509(b.get(), nullptr, nullptr, nullptr) : nullptr, &X509_free};
}

std::unique_ptr<X509_STORE, decltype(&X509_STORE_free)> store_of(const fs::path& ca) {
  std::unique_ptr<X509_STORE, decltype(&X509_STORE_free)> s(X509_STORE_new(), &X509_STORE_free);
  const auto c = load_cert(ca);
  if (c) X509_STORE_add_cert(s.get(), c.get());
  return s;
}

bool cert_verifies(const fs::path& cert, const fs::path& ca) {
  const auto c = load_cert(cert);
  auto store = store_of(ca);
  std::unique_ptr<X509_STORE_CTX, decltype(&X509_STORE_CTX_free)> ctx(X509_STORE_CTX_new(), &X509_STORE_CTX_free);
  if (!c || X509_STORE_CTX_init(ctx.get(), store.get(), c.get(), nullptr) != 1) return false;
  return X509_verify_cert(ctx.get()) == 1;
}

// The signed content when the S/MIME text verifies against `ca` (as Cyclone's access control
// reads it: PKCS7_TEXT strips the text/plain header); nullopt otherwise.
std::optional<std::string> smime_content(const std::string& smime, const fs::path& ca) {
  std::unique_ptr<BIO, decltype(&BIO_free)> in(BIO_new_mem_buf(smime.data(), static_cast<int>(smime.size())),
                                               &BIO_free);
  BIO* content = nullptr;
  std::unique_ptr<PKCS7, decltype(&PKCS7_free)> p7(SMIME_read_PKCS7(in.get(), &content), &PKCS7_free);
  std::unique_ptr<BIO, decltype(&BIO_free)> content_owner(content, &BIO_free);
  if (!p7 || content == nullptr) return std::nullopt;
  auto store = store_of(ca);
  std::unique_ptr<BIO, decltype(&BIO_free)> out(BIO_new(BIO_s_mem()), &BIO_free);
  if (PKCS7_verify(p7.get(), nullptr, store.get(), content, out.get(), PKCS7_TEXT) != 1) return std::nullopt;
  char* data = nullptr;
  const long n = BIO_get_mem_data(out.get(), &data);  // NOLINT(google-runtime-int): OpenSSL's type
  std::string text(data, static_cast<std::size_t>(n));
  std::erase(text, '\r');  // S/MIME text is canonical CRLF
  return text;
}

std::string subject_rfc2253(const fs::path& cert) {
  const auto c = load_cert(cert);
  std::unique_ptr<BIO, decltype(&BIO_free)> b(BIO_new(BIO_s_mem()), &BIO_free);
  X509_NAME_print_ex(b.get(), X509_get_subject_name(c.get()), 0, XN_FLAG_RFC2253);
  char* data = nullptr;
  const long n = BIO_get_mem_data(b.get(), &data);  // NOLINT(google-runtime-int): OpenSSL's type
  return {data, static_cast<std::size_t>(n)};
}

std::string between(const std::string& s, const std::string& open, const std::string& close) {
  const auto a = s.find(open);
  if (a == std::string::npos) return {};
  const auto b = s.find(close, a + open.size());
  return b == std::string::npos ? std::string() : s.substr(a + open.size(), b - a - open.size());
}

TEST(SecurityInit, CertificatesSignaturesSubjectsAndGrants) {
  Dir d;
  dds::SecurityInitOptions o;
  o.dir = (d.path / "sec").string();
  o.commanders = {"dbw_command", "teleop"};
  const auto files = dds::init_security_dir(o);
  EXPECT_EQ(files.size(), 7U + 4U * 4U);  // 2 CAs + keys, governance x2, revocation list
  const fs::path s = o.dir;
  const auto id_ca = s / "identity_ca.pem";
  const auto perm_ca = s / "permissions_ca.pem";

  const auto gov = read(s / "governance.p7s");
  const auto gov_xml = smime_content(gov, perm_ca);
  ASSERT_TRUE(gov_xml.has_value()) << "governance does not verify with the permissions CA";
  EXPECT_EQ(*gov_xml, read(s / "governance.xml"));
  EXPECT_FALSE(smime_content(gov, id_ca).has_value()) << "governance verifies with the identity CA";
  std::string tampered = gov;
  const std::string wac = "<enable_write_access_control>true";  // the command topic's
  tampered.replace(tampered.find(wac), wac.size(), "<enable_write_access_control>false");
  EXPECT_FALSE(smime_content(tampered, perm_ca).has_value()) << "a changed governance still verifies";
  // The command topic's rule comes first (first match wins) and controls both directions.
  const std::string cmd_rule = between(*gov_xml, "<topic_expression>rt/vehicle/dbw/cmd</topic_expression>", "</topic_rule>");
  EXPECT_LT(gov_xml->find("rt/vehicle/dbw/cmd"), gov_xml->find("<topic_expression>*</topic_expression>"));
  EXPECT_NE(cmd_rule.find("<enable_write_access_control>true"), std::string::npos);
  EXPECT_NE(cmd_rule.find("<enable_read_access_control>true"), std::string::npos);
  EXPECT_NE(cmd_rule.find("<metadata_protection_kind>SIGN_WITH_ORIGIN_AUTHENTICATION"), std::string::npos);
  EXPECT_NE(gov_xml->find("<allow_unauthenticated_participants>true"), std::string::npos);

  for (const std::string id : {"dbw_bridge", "dbw_command", "teleop", "reader"}) {
    SCOPED_TRACE(id);
    EXPECT_TRUE(cert_verifies(s / id / "cert.pem", id_ca));
    EXPECT_FALSE(cert_verifies(s / id / "cert.pem", perm_ca));
    const auto perms = smime_content(read(s / id / "permissions.p7s"), perm_ca);
    ASSERT_TRUE(perms.has_value()) << "permissions do not verify with the permissions CA";
    EXPECT_EQ(*perms, read(s / id / "permissions.xml"));
    EXPECT_FALSE(smime_content(read(s / id / "permissions.p7s"), id_ca).has_value());
    EXPECT_EQ(between(*perms, "<subject_name>", "</subject_name>"), subject_rfc2253(s / id / "cert.pem"));
    EXPECT_EQ(subject_rfc2253(s / id / "cert.pem"), "CN=" + id + ",O=sensor-rig");
    const std::string publish = between(*perms, "<publish>", "</publish>");
    const std::string subscribe = between(*perms, "<subscribe>", "</subscribe>");
    const bool commander = id == "dbw_command" || id == "teleop";
    EXPECT_EQ(publish.find("rt/vehicle/dbw/cmd") != std::string::npos, commander) << publish;
    if (id == "dbw_bridge") {
      EXPECT_NE(subscribe.find("<topic>rt/vehicle/dbw/cmd</topic>"), std::string::npos);
    }
    if (id == "reader") {
      EXPECT_TRUE(publish.empty()) << "reader may publish: " << publish;
    }
    EXPECT_NE(perms->find("<default>DENY</default>"), std::string::npos);
    EXPECT_EQ(fs::status(s / id / "key.pem").permissions() & (fs::perms::group_all | fs::perms::others_all),
              fs::perms::none);
  }
  EXPECT_EQ(fs::status(s / "private").permissions() & (fs::perms::group_all | fs::perms::others_all), fs::perms::none);

  EXPECT_THROW(dds::init_security_dir(o), std::runtime_error);  // already there, no --force
  o.force = true;
  o.key_type = dds::KeyType::kRsa2048;
  o.allow_unauthenticated = false;
  o.commanders.clear();  // RSA keys are slow to make: three are enough
  o.readers.clear();
  EXPECT_NO_THROW(dds::init_security_dir(o));
  const auto cert = load_cert(s / "dbw_bridge/cert.pem");
  EXPECT_EQ(EVP_PKEY_get_base_id(X509_get0_pubkey(cert.get())), EVP_PKEY_RSA);
  EXPECT_EQ(EVP_PKEY_get_bits(X509_get0_pubkey(cert.get())), 2048);
  EXPECT_TRUE(cert_verifies(s / "dbw_bridge/cert.pem", id_ca));
  EXPECT_NE(read(s / "governance.xml").find("<allow_unauthenticated_participants>false"), std::string::npos);
}

TEST(SecurityInit, CommandProtectionKindOnlyInTheCommandRule) {
  for (const auto& [p, word] : std::vector<std::pair<dds::Protection, std::string>>{
           {dds::Protection::kNone, "NONE"},
           {dds::Protection::kSign, "SIGN"},
           {dds::Protection::kEncrypt, "ENCRYPT"},
           {dds::Protection::kSignOrigin, "SIGN_WITH_ORIGIN_AUTHENTICATION"},
           {dds::Protection::kEncryptOrigin, "ENCRYPT_WITH_ORIGIN_AUTHENTICATION"}}) {
    const std::string xml = dds::governance_xml(true, p);
    const std::string cmd = between(xml, "<topic_expression>rt/vehicle/dbw/cmd</topic_expression>", "</topic_rule>");
    const std::string rest = between(xml, "<topic_expression>*</topic_expression>", "</topic_rule>");
    EXPECT_NE(cmd.find("<metadata_protection_kind>" + word + "</metadata_protection_kind>"), std::string::npos) << word;
    EXPECT_NE(rest.find("<metadata_protection_kind>NONE</metadata_protection_kind>"), std::string::npos) << word;
  }
}

TEST(SecurityInit, RefusesBadNames) {
  Dir d;
  dds::SecurityInitOptions o;
  o.dir = (d.path / "sec").string();
  for (const std::string bad : {"", "a/b", "a b", "x<y", "private"}) {
    o.bridge = bad;
    EXPECT_THROW(dds::init_security_dir(o), std::runtime_error) << "'" << bad << "'";
  }
  o.bridge = "dbw_command";  // also a command source
  EXPECT_THROW(dds::init_security_dir(o), std::runtime_error);
  EXPECT_FALSE(fs::exists(d.path / "sec" / "identity_ca.pem")) << "files written before the names were checked";
}

// `rig security add-identity`: signed by the CAs already there (identities deployed before stay
// valid, their files untouched); the grant follows --permit-command; no CA, a name already there
// and a bad name are refused before anything is written.
TEST(SecurityAddIdentity, SignedByTheExistingCasAndNothingElseChanges) {
  Dir d;
  dds::SecurityInitOptions o;
  o.dir = (d.path / "sec").string();
  o.organization = "e-class";
  dds::init_security_dir(o);
  const fs::path s = o.dir;
  const std::string before = read(s / "identity_ca.pem") + read(s / "dbw_command/cert.pem") +
                             read(s / "dbw_command/permissions.p7s") + read(s / "governance.p7s");

  dds::AddIdentityOptions a;
  a.dir = o.dir;
  a.name = "planner";
  a.role = dds::Role::kCommander;
  EXPECT_EQ(dds::add_identity(a).size(), 4U);
  a.name = "logger";
  a.role = dds::Role::kReader;
  EXPECT_EQ(dds::add_identity(a).size(), 4U);
  EXPECT_EQ(read(s / "identity_ca.pem") + read(s / "dbw_command/cert.pem") + read(s / "dbw_command/permissions.p7s") +
                read(s / "governance.p7s"),
            before);
  for (const std::string id : {"planner", "logger"}) {
    SCOPED_TRACE(id);
    EXPECT_TRUE(cert_verifies(s / id / "cert.pem", s / "identity_ca.pem"));
    EXPECT_EQ(subject_rfc2253(s / id / "cert.pem"), "CN=" + id + ",O=e-class");  // the CA's organization
    const auto perms = smime_content(read(s / id / "permissions.p7s"), s / "permissions_ca.pem");
    ASSERT_TRUE(perms.has_value()) << "permissions do not verify with the permissions CA";
    EXPECT_EQ(between(*perms, "<subject_name>", "</subject_name>"), subject_rfc2253(s / id / "cert.pem"));
    const std::string publish = between(*perms, "<publish>", "</publish>");
    EXPECT_EQ(publish.find("rt/vehicle/dbw/cmd") != std::string::npos, id == "planner") << publish;
    EXPECT_EQ(fs::status(s / id / "key.pem").permissions() & (fs::perms::group_all | fs::perms::others_all),
              fs::perms::none);
  }

  const auto error_of = [](const dds::AddIdentityOptions& opts) {
    try {
      dds::add_identity(opts);
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of(a).find("identity 'logger' already exists"), std::string::npos) << error_of(a);
  a.name = "a/b";
  EXPECT_NE(error_of(a).find("identity name 'a/b'"), std::string::npos) << error_of(a);
  a.name = "teleop";
  a.dir = (d.path / "no_ca").string();
  EXPECT_NE(error_of(a).find("holds no complete CA (missing identity_ca.pem"), std::string::npos) << error_of(a);
  fs::remove(s / "private/permissions_ca_key.pem");  // the CA keys stay off the car
  a.dir = o.dir;
  EXPECT_NE(error_of(a).find("(missing private/permissions_ca_key.pem)"), std::string::npos) << error_of(a);
  EXPECT_FALSE(fs::exists(s / "teleop")) << "files written for a refused identity";
}

std::string dbw_problems(const std::string& yaml, sensor_rig::drivers::DbwConfig* out = nullptr) {
  auto problems = std::make_shared<config::Problems>();
  const auto node = config::Node::load_string(yaml, "rig.yaml", problems);
  const auto d = sensor_rig::drivers::parse_dbw_config(node);
  if (out != nullptr) *out = d;
  return problems->str();
}

TEST(DbwSecurityConfig, ValidatedAtLoadWithPositions) {
  Dir d;
  dds::SecurityInitOptions o;
  o.dir = (d.path / "sec").string();
  dds::init_security_dir(o);

  sensor_rig::drivers::DbwConfig c;
  EXPECT_EQ(dbw_problems("command_source: {rate_hz: 50}\nsecurity:\n  dir: " + o.dir + "\n", &c), "");
  EXPECT_TRUE(c.security.enabled);
  EXPECT_EQ(sensor_rig::drivers::security_args(c, true),
            (std::vector<std::string>{"--security", o.dir, "--identity", "dbw_bridge"}));
  EXPECT_EQ(sensor_rig::drivers::security_args(c, false),
            (std::vector<std::string>{"--security", o.dir, "--identity", "dbw_command"}));

  EXPECT_EQ(dbw_problems("security: {dir: " + o.dir + ", enabled: false}\n", &c), "");
  EXPECT_TRUE(sensor_rig::drivers::security_args(c, true).empty());

  std::string p = dbw_problems("security:\n  enabled: true\n");
  EXPECT_NE(p.find("rig.yaml:2:3: security.dir: required key is missing"), std::string::npos) << p;
  p = dbw_problems("security:\n  dir: " + (d.path / "none").string() + "\n");
  EXPECT_NE(p.find("rig.yaml:2:8: security.dir: not a directory"), std::string::npos) << p;
  p = dbw_problems("command_source: {rate_hz: 50}\nsecurity:\n  dir: " + o.dir + "\n  command_identity: teleop\n");
  EXPECT_NE(p.find("rig.yaml:4:21: security.command_identity: DDS Security: identity 'teleop'"), std::string::npos) << p;
  p = dbw_problems("security:\n  dir: " + o.dir + "\n  identity: x\n");
  EXPECT_NE(p.find("rig.yaml:3:3: security.identity: unknown key"), std::string::npos) << p;
  // Issue 28: a key others may read is a config problem at load, not a surprise at `rig up`.
  fs::permissions(fs::path(o.dir) / "dbw_bridge/key.pem", fs::perms::others_read, fs::perm_options::add);
  p = dbw_problems("security:\n  dir: " + o.dir + "\n");
  EXPECT_NE(p.find("rig.yaml:2:8: security.dir: DDS Security: private key of identity 'dbw_bridge'"), std::string::npos)
      << p;
  EXPECT_NE(p.find("(mode 0604)"), std::string::npos) << p;
}

}  // namespace
