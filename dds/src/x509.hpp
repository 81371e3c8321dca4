#pragma once
// Private to dds/: the few OpenSSL (libcrypto) operations `rig security init` needs, RAII-owned,
// every failure thrown with OpenSSL's own error text.
#include <openssl/evp.h>
#include <openssl/x509.h>

#include <memory>
#include <string>

#include "sensor_rig/dds/security_init.hpp"

namespace sensor_rig::dds::x509 {

struct KeyFree {
  void operator()(EVP_PKEY* k) const { EVP_PKEY_free(k); }
};
struct CertFree {
  void operator()(X509* c) const { X509_free(c); }
};
using Key = std::unique_ptr<EVP_PKEY, KeyFree>;
using Cert = std::unique_ptr<X509, CertFree>;

Key make_key(KeyType t);
// A certificate for `key` named CN=common_name,O=organization, signed by issuer/issuer_key (self-signed
// when issuer is null). ca: a CA certificate (basicConstraints CA:TRUE, keyCertSign).
Cert make_cert(const std::string& common_name, const std::string& organization, EVP_PKEY* key, X509* issuer,
               EVP_PKEY* issuer_key, int days, bool ca);

// PEM files written by write_cert / write_key (or openssl); throw naming the file.
Cert read_cert(const std::string& path);
Key read_key(const std::string& path);
KeyType key_type_of(EVP_PKEY* key);
// The O= of a certificate's subject ("" when it has none).
std::string organization_of(X509* cert);

// PEM files; the key file is created 0600.
void write_cert(const std::string& path, X509* cert);
void write_key(const std::string& path, EVP_PKEY* key);
// `text` as S/MIME (multipart/signed, detached PKCS#7, text/plain part) signed by cert/key, as
// `openssl smime -sign -text` writes it and Cyclone's access control plugin reads it.
void write_smime(const std::string& path, const std::string& text, X509* cert, EVP_PKEY* key);

}  // namespace sensor_rig::dds::x509
