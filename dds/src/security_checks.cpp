// What `security_files` checks before Cyclone reads an identity (issue 28): a private key that
// others may read, a governance under which Cyclone 0.10.2 lets a participant without credentials
// write the command topic; and when the identity expires, for /diagnostics.
#include <fnmatch.h>
#include <sys/stat.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "sensor_rig/dds/security.hpp"
#include "sensor_rig/dds/security_init.hpp"
#include "x509.hpp"

namespace sensor_rig::dds {
namespace {

std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  if (!in) throw std::runtime_error("DDS Security: cannot read '" + path + "'");
  return s.str();
}

// The text between <tag> and </tag> from `from`, whitespace trimmed; npos in `end` when absent.
std::string element(const std::string& xml, const std::string& tag, std::size_t from = 0, std::size_t* end = nullptr) {
  const std::string open = "<" + tag + ">";
  const std::string close = "</" + tag + ">";
  const auto a = xml.find(open, from);
  const auto b = a == std::string::npos ? a : xml.find(close, a);
  if (end != nullptr) *end = b == std::string::npos ? b : b + close.size();
  if (b == std::string::npos) return {};
  std::string v = xml.substr(a + open.size(), b - a - open.size());
  const auto first = v.find_first_not_of(" \t\r\n");
  const auto last = v.find_last_not_of(" \t\r\n");
  return first == std::string::npos ? std::string() : v.substr(first, last - first + 1);
}

std::time_t parse_utc(const std::string& s) {
  std::tm tm{};
  if (s.empty() || ::strptime(s.c_str(), "%Y-%m-%dT%H:%M:%S", &tm) == nullptr) return 0;
  return timegm(&tm);
}
}  // namespace

void check_governance(const std::string& governance, const std::string& where) {
  if (element(governance, "allow_unauthenticated_participants") != "true") return;  // strangers ignored
  // Cyclone applies the first topic rule whose expression matches (fnmatch), as we do here.
  std::size_t pos = 0;
  std::size_t end = 0;
  for (std::string rule; !(rule = element(governance, "topic_rule", pos, &end)).empty(); pos = end) {
    if (::fnmatch(element(rule, "topic_expression").c_str(), kProtectedCommandTopic, 0) != 0) continue;
    const bool write_controlled = element(rule, "enable_write_access_control") == "true";
    const bool signed_or_encrypted = element(rule, "metadata_protection_kind") != "NONE" ||
                            element(rule, "data_protection_kind") != "NONE";
    if (write_controlled && signed_or_encrypted) return;
    throw std::runtime_error(
        "DDS Security: " + where + " lets a participant without credentials write " + kProtectedCommandTopic +
        ": allow_unauthenticated_participants with " +
        (write_controlled ? "neither metadata nor data protection" : "no write access control") +
        " on its rule (Cyclone 0.10.2 then matches unauthenticated writers without asking access control); "
        "make it again with `rig security init --cmd-protection sign-origin` (or `none --no-unauthenticated`)");
  }
  throw std::runtime_error("DDS Security: " + where + " has no topic rule for " + kProtectedCommandTopic);
}

void check_private_key_mode(const std::string& path, const std::string& identity) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw std::runtime_error("DDS Security: cannot stat '" + path + "'");
  if ((st.st_mode & 077U) == 0) return;
  char mode[8];
  std::snprintf(mode, sizeof mode, "%04o", st.st_mode & 07777U);
  throw std::runtime_error("DDS Security: private key of identity '" + identity + "' (" + path +
                           ") is readable or writable by group or others (mode " + mode + "); refused: `chmod 600 " +
                           path + "`, and treat the key as exposed if others could read it");
}

SecurityExpiry security_expiry(const SecurityConfig& c) {
  SecurityExpiry e;
  const auto earliest = [&](std::time_t t, const char* what) {
    if (t > 0 && (e.not_after == 0 || t < e.not_after)) e = {t, what};
  };
  earliest(x509::not_after_of(x509::read_cert(c.identity_certificate).get()), "certificate");
  // The grant's validity, as the signed text carries it (S/MIME text/plain: the XML as written).
  const std::time_t grant = parse_utc(element(read_all(c.permissions), "not_after"));
  if (grant == 0) throw std::runtime_error("DDS Security: no <not_after> in '" + c.permissions + "'");
  earliest(grant, "grant");
  earliest(x509::not_after_of(x509::read_cert(c.identity_ca).get()), "identity CA");
  earliest(x509::not_after_of(x509::read_cert(c.permissions_ca).get()), "permissions CA");
  if (!c.crl.empty()) earliest(x509::next_update_of(x509::read_crl(c.crl).get()), "revocation list");
  return e;
}

void report_expiry(DriverStatus& d, const std::string& identity, const SecurityExpiry& e, std::time_t now) {
  std::tm tm{};
  gmtime_r(&e.not_after, &tm);
  char when[32];
  std::strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%SZ", &tm);
  const long long days_left = (static_cast<long long>(e.not_after) - now) / 86400;
  d.add("security_identity", identity);
  d.add("security_expires", std::string(when) + " (" + e.what + ")");
  d.add_number("security_days_left", days_left);
  if (e.not_after <= now) {
    d.level = Level::kError;
    d.message += "; DDS Security " + e.what + " of '" + identity + "' expired " + when;
  } else if (days_left < kExpiryWarnDays) {
    if (d.level == Level::kOk) d.level = Level::kWarn;
    d.message += "; DDS Security " + e.what + " of '" + identity + "' expires " + when + " (" +
                 std::to_string(days_left) + " days)";
  }
}

}  // namespace sensor_rig::dds
