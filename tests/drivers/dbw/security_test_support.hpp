#pragma once
// Helpers of the DDS Security tests: a temporary directory, file text and modes, certificates
// read with OpenSSL directly (not through the code under test), and a certificate made to have
// expired (re-signed by its CA with validity in the past: no `rig` command makes one).
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <stdlib.h>
#include <sys/stat.h>

#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

namespace sensor_rig::dds::test {
namespace fs = std::filesystem;

inline std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline unsigned mode_of(const fs::path& p) {
  struct stat st {};
  return ::lstat(p.c_str(), &st) == 0 ? st.st_mode & 07777U : 0xFFFFU;
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
inline CertPtr load_cert(const fs::path& p) {
  std::unique_ptr<BIO, decltype(&BIO_free)> b(BIO_new_file(p.c_str(), "r"), &BIO_free);
  return {b ? PEM_read_bio_X509(b.get(), nullptr, nullptr, nullptr) : nullptr, &X509_free};
}

inline std::time_t not_after(const fs::path& cert) {
  const auto c = load_cert(cert);
  std::tm tm{};
  if (!c || ASN1_TIME_to_tm(X509_get0_notAfter(c.get()), &tm) != 1) return 0;
  return timegm(&tm);
}

// DIR/NAME/cert.pem re-signed by DIR's identity CA with validity [now - 10 days, now - 1 day].
inline bool expire_certificate(const fs::path& dir, const std::string& name) {
  const auto cert = load_cert(dir / name / "cert.pem");
  std::unique_ptr<BIO, decltype(&BIO_free)> kb(BIO_new_file((dir / "private/identity_ca_key.pem").c_str(), "r"),
                                               &BIO_free);
  std::unique_ptr<EVP_PKEY, decltype(&EVP_PKEY_free)> key(
      kb ? PEM_read_bio_PrivateKey(kb.get(), nullptr, nullptr, nullptr) : nullptr, &EVP_PKEY_free);
  if (!cert || !key) return false;
  if (X509_gmtime_adj(X509_getm_notBefore(cert.get()), -10L * 86400) == nullptr ||
      X509_gmtime_adj(X509_getm_notAfter(cert.get()), -86400L) == nullptr ||
      X509_sign(cert.get(), key.get(), EVP_sha256()) <= 0)
    return false;
  std::unique_ptr<BIO, decltype(&BIO_free)> out(BIO_new_file((dir / name / "cert.pem").c_str(), "w"), &BIO_free);
  return out && PEM_write_bio_X509(out.get(), cert.get()) == 1;
}

}  // namespace sensor_rig::dds::test
