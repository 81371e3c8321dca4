// Certificate revocation lists for `rig security revoke` (x509.hpp). Cyclone 0.10.2's
// authentication plugin (auth_utils.c verify_certificate) adds the CRL to the store and sets
// X509_V_FLAG_CRL_CHECK for the local certificate and every peer's, so the CRL must be there from
// the first participant on (an empty one after `init`) and valid for as long as the CA.
#include <openssl/bn.h>
#include <openssl/pem.h>
#include <openssl/x509v3.h>

#include <algorithm>
#include <stdexcept>

#include "x509.hpp"

namespace sensor_rig::dds::x509 {
namespace {
std::string decimal(const ASN1_INTEGER* i) {
  std::unique_ptr<BIGNUM, decltype(&BN_free)> bn(ASN1_INTEGER_to_BN(i, nullptr), &BN_free);
  if (!bn) fail("serial number");
  char* dec = BN_bn2dec(bn.get());
  if (dec == nullptr) fail("BN_bn2dec");
  std::string s(dec);
  OPENSSL_free(dec);
  return s;
}

std::unique_ptr<ASN1_INTEGER, decltype(&ASN1_INTEGER_free)> integer(const std::string& dec) {
  BIGNUM* raw = nullptr;
  if (BN_dec2bn(&raw, dec.c_str()) == 0) fail("serial '" + dec + "'");
  std::unique_ptr<BIGNUM, decltype(&BN_free)> bn(raw, &BN_free);
  std::unique_ptr<ASN1_INTEGER, decltype(&ASN1_INTEGER_free)> i(BN_to_ASN1_INTEGER(bn.get(), nullptr),
                                                                &ASN1_INTEGER_free);
  if (!i) fail("BN_to_ASN1_INTEGER");
  return i;
}

std::unique_ptr<ASN1_TIME, decltype(&ASN1_TIME_free)> asn1_time(std::time_t t) {
  std::unique_ptr<ASN1_TIME, decltype(&ASN1_TIME_free)> a(ASN1_TIME_set(nullptr, t), &ASN1_TIME_free);
  if (!a) fail("ASN1_TIME_set");
  return a;
}
}  // namespace

Crl make_crl(X509* ca, EVP_PKEY* ca_key, const std::vector<std::string>& serials, std::time_t next_update) {
  Crl crl(X509_CRL_new());
  if (!crl) fail("X509_CRL_new");
  if (X509_CRL_set_version(crl.get(), 1) != 1) fail("X509_CRL_set_version");  // v2: extensions allowed
  if (X509_CRL_set_issuer_name(crl.get(), X509_get_subject_name(ca)) != 1) fail("X509_CRL_set_issuer_name");
  const std::time_t now = std::time(nullptr);
  if (X509_CRL_set1_lastUpdate(crl.get(), asn1_time(now - 60).get()) != 1) fail("lastUpdate");
  if (X509_CRL_set1_nextUpdate(crl.get(), asn1_time(next_update).get()) != 1) fail("nextUpdate");
  for (const auto& s : serials) {
    X509_REVOKED* r = X509_REVOKED_new();
    if (r == nullptr) fail("X509_REVOKED_new");
    if (X509_REVOKED_set_serialNumber(r, integer(s).get()) != 1 ||
        X509_REVOKED_set_revocationDate(r, asn1_time(now - 60).get()) != 1 || X509_CRL_add0_revoked(crl.get(), r) != 1) {
      X509_REVOKED_free(r);
      fail("revoked entry " + s);
    }
  }
  if (X509_CRL_sort(crl.get()) != 1) fail("X509_CRL_sort");
  if (X509_CRL_sign(crl.get(), ca_key, EVP_sha256()) <= 0) fail("X509_CRL_sign");
  return crl;
}

Crl read_crl(const std::string& path) {
  Bio b(BIO_new_file(path.c_str(), "r"));
  if (!b) fail("cannot read '" + path + "'");
  Crl c(PEM_read_bio_X509_CRL(b.get(), nullptr, nullptr, nullptr));
  if (!c) fail("'" + path + "' is not a PEM certificate revocation list");
  return c;
}

void write_crl(const std::string& path, X509_CRL* crl) {
  Bio b(BIO_new(BIO_s_mem()));
  if (!b) fail("BIO_new");
  if (PEM_write_bio_X509_CRL(b.get(), crl) != 1) fail("PEM_write_bio_X509_CRL");
  char* data = nullptr;
  const long n = BIO_get_mem_data(b.get(), &data);  // NOLINT(google-runtime-int): OpenSSL's type
  write_file(path, std::string(data, static_cast<std::size_t>(n)), 0644);
}

std::vector<std::string> revoked_serials(X509_CRL* crl) {
  std::vector<std::string> out;
  STACK_OF(X509_REVOKED)* revoked = X509_CRL_get_REVOKED(crl);
  out.reserve(static_cast<std::size_t>(std::max(0, sk_X509_REVOKED_num(revoked))));
  for (int i = 0; i < sk_X509_REVOKED_num(revoked); ++i)
    out.push_back(decimal(X509_REVOKED_get0_serialNumber(sk_X509_REVOKED_value(revoked, i))));
  return out;
}

std::string serial_of(X509* cert) { return decimal(X509_get0_serialNumber(cert)); }

std::time_t next_update_of(const X509_CRL* crl) {
  const ASN1_TIME* t = X509_CRL_get0_nextUpdate(crl);
  std::tm tm{};
  if (t == nullptr || ASN1_TIME_to_tm(t, &tm) != 1) return 0;
  return timegm(&tm);
}

}  // namespace sensor_rig::dds::x509
