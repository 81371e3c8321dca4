#pragma once
// Private to dds/: the few OpenSSL (libcrypto) operations `rig security init` needs, RAII-owned,
// every failure thrown with OpenSSL's own error text.
#include <openssl/bio.h>
#include <openssl/evp.h>
#include <openssl/x509.h>

#include <cstdint>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include "sensor_rig/dds/security_init.hpp"

namespace sensor_rig::dds::x509 {

struct KeyFree {
  void operator()(EVP_PKEY* k) const { EVP_PKEY_free(k); }
};
struct CertFree {
  void operator()(X509* c) const { X509_free(c); }
};
struct BioFree {
  void operator()(BIO* b) const { BIO_free_all(b); }
};
struct CrlFree {
  void operator()(X509_CRL* c) const { X509_CRL_free(c); }
};
using Key = std::unique_ptr<EVP_PKEY, KeyFree>;
using Cert = std::unique_ptr<X509, CertFree>;
using Crl = std::unique_ptr<X509_CRL, CrlFree>;
using Bio = std::unique_ptr<BIO, BioFree>;

// Throws std::runtime_error("OpenSSL: what: <OpenSSL's queued errors>").
[[noreturn]] void fail(const std::string& what);

Key make_key(KeyType t);
// A certificate for `key` named CN=common_name,O=organization, signed by issuer/issuer_key (self-signed
// when issuer is null), valid from a day ago until not_after. ca: a CA certificate (basicConstraints
// CA:TRUE, keyCertSign).
Cert make_cert(const std::string& common_name, const std::string& organization, EVP_PKEY* key, X509* issuer,
               EVP_PKEY* issuer_key, std::time_t not_after, bool ca);
// notAfter of a certificate, as time_t (UTC).
std::time_t not_after_of(const X509* cert);

// PEM files written by write_cert / write_key (or openssl); throw naming the file.
Cert read_cert(const std::string& path);
Key read_key(const std::string& path);
KeyType key_type_of(EVP_PKEY* key);
// The O= of a certificate's subject ("" when it has none).
std::string organization_of(X509* cert);

// Writes `bytes` to `path` with `mode`: a new file beside it (O_CREAT|O_EXCL|O_NOFOLLOW, the mode
// set before a byte is written), fsync, then rename over `path`. A symlink at `path` is replaced,
// never written through; a reader sees the old file or the new one, never a part; an earlier
// file's looser mode does not survive.
void write_file(const std::string& path, const std::string& bytes, unsigned mode);

// PEM files (atomically, as write_file); the key file 0600, the others 0644.
void write_cert(const std::string& path, X509* cert);
void write_key(const std::string& path, EVP_PKEY* key);
// `text` as S/MIME (multipart/signed, detached PKCS#7, text/plain part) signed by cert/key, as
// `openssl smime -sign -text` writes it and Cyclone's access control plugin reads it.
void write_smime(const std::string& path, const std::string& text, X509* cert, EVP_PKEY* key);

// Certificate revocation lists (x509_crl.cpp): Cyclone 0.10.2's authentication plugin checks
// every certificate, its own and each peer's, against the CRL of `org.eclipse.cyclonedds.sec.auth.crl`.
// A CRL of `ca` revoking `serials` (decimal strings), signed by ca_key, valid until next_update.
Crl make_crl(X509* ca, EVP_PKEY* ca_key, const std::vector<std::string>& serials, std::time_t next_update);
Crl read_crl(const std::string& path);
void write_crl(const std::string& path, X509_CRL* crl);
std::vector<std::string> revoked_serials(X509_CRL* crl);  // decimal
std::string serial_of(X509* cert);                        // decimal
// nextUpdate of a CRL (0 when it has none).
std::time_t next_update_of(const X509_CRL* crl);

}  // namespace sensor_rig::dds::x509
