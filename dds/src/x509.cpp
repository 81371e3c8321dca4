#include "x509.hpp"

#include <fcntl.h>
#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/pkcs7.h>
#include <openssl/rand.h>
#include <openssl/rsa.h>
#include <openssl/x509v3.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace sensor_rig::dds::x509 {

void fail(const std::string& what) {
  std::string detail;
  while (const unsigned long e = ERR_get_error()) {  // NOLINT(google-runtime-int): OpenSSL's type
    char buf[256];
    ERR_error_string_n(e, buf, sizeof buf);
    detail += std::string(detail.empty() ? "" : "; ") + buf;
  }
  throw std::runtime_error("OpenSSL: " + what + (detail.empty() ? "" : ": " + detail));
}

namespace {
void ok(int rc, const char* what) {
  if (rc <= 0) fail(what);
}

void add_ext(X509* cert, X509* issuer, int nid, const char* value) {
  X509V3_CTX ctx;
  X509V3_set_ctx(&ctx, issuer, cert, nullptr, nullptr, 0);
  X509_EXTENSION* ext = X509V3_EXT_conf_nid(nullptr, &ctx, nid, value);
  if (ext == nullptr) fail(std::string("extension ") + value);
  const int rc = X509_add_ext(cert, ext, -1);
  X509_EXTENSION_free(ext);
  ok(rc, "X509_add_ext");
}

// The bytes a PEM/S-MIME writer put into a memory BIO.
std::string bytes_of(BIO* mem) {
  char* data = nullptr;
  const long n = BIO_get_mem_data(mem, &data);  // NOLINT(google-runtime-int): OpenSSL's type
  return n > 0 ? std::string(data, static_cast<std::size_t>(n)) : std::string();
}

Bio mem_bio() {
  Bio b(BIO_new(BIO_s_mem()));
  if (!b) fail("BIO_new");
  return b;
}
}  // namespace

Key make_key(KeyType t) {
  Key k(t == KeyType::kEcP256 ? EVP_EC_gen("P-256") : EVP_RSA_gen(2048));
  if (!k) fail("key generation");
  return k;
}

Cert make_cert(const std::string& common_name, const std::string& organization, EVP_PKEY* key, X509* issuer,
               EVP_PKEY* issuer_key, std::time_t not_after, bool ca) {
  Cert c(X509_new());
  if (!c) fail("X509_new");
  ok(X509_set_version(c.get(), 2), "X509_set_version");
  std::uint64_t serial = 0;
  ok(RAND_bytes(reinterpret_cast<unsigned char*>(&serial), sizeof serial), "RAND_bytes");
  ok(ASN1_INTEGER_set_uint64(X509_get_serialNumber(c.get()), serial >> 1), "serial");  // positive
  if (X509_gmtime_adj(X509_getm_notBefore(c.get()), -86400) == nullptr) fail("notBefore");
  if (ASN1_TIME_set(X509_getm_notAfter(c.get()), not_after) == nullptr) fail("notAfter");
  ok(X509_set_pubkey(c.get(), key), "X509_set_pubkey");
  X509_NAME* name = X509_get_subject_name(c.get());
  // O first, then CN: RFC 2253 (last first) reads "CN=...,O=...", the grants' subject_name.
  const auto add = [&](const char* field, const std::string& v) {
    ok(X509_NAME_add_entry_by_txt(name, field, MBSTRING_UTF8, reinterpret_cast<const unsigned char*>(v.c_str()), -1,
                                  -1, 0),
       field);
  };
  add("O", organization);
  add("CN", common_name);
  X509* signer = issuer != nullptr ? issuer : c.get();
  ok(X509_set_issuer_name(c.get(), X509_get_subject_name(signer)), "X509_set_issuer_name");
  add_ext(c.get(), signer, NID_basic_constraints, ca ? "critical,CA:TRUE" : "critical,CA:FALSE");
  add_ext(c.get(), signer, NID_key_usage,
          ca ? "critical,keyCertSign,cRLSign,digitalSignature" : "critical,digitalSignature,keyAgreement");
  add_ext(c.get(), signer, NID_subject_key_identifier, "hash");
  if (issuer != nullptr) add_ext(c.get(), signer, NID_authority_key_identifier, "keyid:always");
  ok(X509_sign(c.get(), issuer_key != nullptr ? issuer_key : key, EVP_sha256()), "X509_sign");
  return c;
}

Cert read_cert(const std::string& path) {
  Bio b(BIO_new_file(path.c_str(), "r"));
  if (!b) fail("cannot read '" + path + "'");
  Cert c(PEM_read_bio_X509(b.get(), nullptr, nullptr, nullptr));
  if (!c) fail("'" + path + "' is not a PEM certificate");
  return c;
}

Key read_key(const std::string& path) {
  Bio b(BIO_new_file(path.c_str(), "r"));
  if (!b) fail("cannot read '" + path + "'");
  Key k(PEM_read_bio_PrivateKey(b.get(), nullptr, nullptr, nullptr));
  if (!k) fail("'" + path + "' is not an unencrypted PEM private key");
  return k;
}

KeyType key_type_of(EVP_PKEY* key) { return EVP_PKEY_is_a(key, "RSA") != 0 ? KeyType::kRsa2048 : KeyType::kEcP256; }

std::string organization_of(X509* cert) {
  X509_NAME* name = X509_get_subject_name(cert);
  const int i = X509_NAME_get_index_by_NID(name, NID_organizationName, -1);
  if (i < 0) return {};
  unsigned char* utf8 = nullptr;
  const int n = ASN1_STRING_to_UTF8(&utf8, X509_NAME_ENTRY_get_data(X509_NAME_get_entry(name, i)));
  if (n < 0) return {};
  std::string o(reinterpret_cast<const char*>(utf8), static_cast<std::size_t>(n));
  OPENSSL_free(utf8);
  return o;
}

std::time_t not_after_of(const X509* cert) {
  std::tm tm{};
  if (ASN1_TIME_to_tm(X509_get0_notAfter(cert), &tm) != 1) fail("notAfter of a certificate");
  return timegm(&tm);
}

void write_file(const std::string& path, const std::string& bytes, unsigned mode) {
  const std::filesystem::path target(path);
  std::string tmp_name = (target.parent_path() / ("." + target.filename().string() + ".XXXXXX")).string();
  // mkstemp's name, then our own open: O_NOFOLLOW and the final mode from the first byte.
  unsigned char rnd[6];
  ok(RAND_bytes(rnd, sizeof rnd), "RAND_bytes");
  static constexpr char kHex[] = "0123456789abcdef";
  for (std::size_t i = 0; i < 6; ++i) tmp_name[tmp_name.size() - 6 + i] = kHex[rnd[i] & 0xf];
  const int fd = ::open(tmp_name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, mode);
  if (fd < 0) throw std::runtime_error("cannot write '" + path + "': " + std::strerror(errno));
  const auto give_up = [&](const char* what) {
    const int e = errno;
    ::close(fd);
    ::unlink(tmp_name.c_str());
    throw std::runtime_error("cannot write '" + path + "': " + what + ": " + std::strerror(e));
  };
  if (::fchmod(fd, mode) != 0) give_up("fchmod");  // the umask narrowed it; never wider than asked
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) give_up("write");
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) give_up("fsync");
  if (::close(fd) != 0) {
    ::unlink(tmp_name.c_str());
    throw std::runtime_error("cannot write '" + path + "': close: " + std::strerror(errno));
  }
  if (::rename(tmp_name.c_str(), path.c_str()) != 0) {
    const int e = errno;
    ::unlink(tmp_name.c_str());
    throw std::runtime_error("cannot write '" + path + "': rename: " + std::strerror(e));
  }
}

void write_cert(const std::string& path, X509* cert) {
  Bio b = mem_bio();
  ok(PEM_write_bio_X509(b.get(), cert), "PEM_write_bio_X509");
  write_file(path, bytes_of(b.get()), 0644);
}

void write_key(const std::string& path, EVP_PKEY* key) {
  Bio b = mem_bio();
  ok(PEM_write_bio_PrivateKey(b.get(), key, nullptr, nullptr, 0, nullptr, nullptr), "PEM_write_bio_PrivateKey");
  std::string pem = bytes_of(b.get());
  write_file(path, pem, 0600);
  OPENSSL_cleanse(pem.data(), pem.size());
}

void write_smime(const std::string& path, const std::string& text, X509* cert, EVP_PKEY* key) {
  Bio in(BIO_new_mem_buf(text.data(), static_cast<int>(text.size())));
  if (!in) fail("BIO_new_mem_buf");
  constexpr int kFlags = PKCS7_DETACHED | PKCS7_TEXT | PKCS7_STREAM;
  std::unique_ptr<PKCS7, decltype(&PKCS7_free)> p7(PKCS7_sign(cert, key, nullptr, in.get(), kFlags), &PKCS7_free);
  if (!p7) fail("PKCS7_sign");
  Bio out = mem_bio();
  ok(SMIME_write_PKCS7(out.get(), p7.get(), in.get(), kFlags), "SMIME_write_PKCS7");
  write_file(path, bytes_of(out.get()), 0644);
}

}  // namespace sensor_rig::dds::x509
