// `rig security revoke DIR NAME`: withdraw an identity with a certificate revocation list.
//
// Why a CRL and not re-signed permissions: a peer receives each participant's permissions from
// that participant in the handshake and checks only their signature and validity, so whoever
// stole NAME's key also holds NAME's old permissions.p7s, still signed and still valid. Cyclone
// 0.10.2's authentication plugin instead checks every peer's certificate against the CRL it was
// given (org.eclipse.cyclonedds.sec.auth.crl; auth_utils.c verify_certificate with
// X509_V_FLAG_CRL_CHECK), which the thief does not control.
#include <openssl/x509v3.h>

#include <algorithm>
#include <filesystem>
#include <stdexcept>

#include "sensor_rig/dds/security_init.hpp"
#include "x509.hpp"

namespace sensor_rig::dds {
namespace fs = std::filesystem;

std::vector<std::string> revoke_identity(const std::string& dir, const std::string& name) {
  const fs::path d(dir);
  for (const char* f : {"identity_ca.pem", "private/identity_ca_key.pem"}) {
    if (!fs::is_regular_file(d / f)) {
      throw std::runtime_error("security revoke: '" + dir + "' has no " + f +
                               " (run it where the CA keys are kept; `rig security init DIR` makes them)");
    }
  }
  const auto ca = x509::read_cert((d / "identity_ca.pem").string());
  const auto ca_key = x509::read_key((d / "private/identity_ca_key.pem").string());
  if (X509_check_private_key(ca.get(), ca_key.get()) != 1)
    throw std::runtime_error("security revoke: private/identity_ca_key.pem is not the key of identity_ca.pem");
  const fs::path crl_path = d / "identity_crl.pem";
  std::vector<std::string> serials;
  if (fs::exists(crl_path)) {
    const auto old = x509::read_crl(crl_path.string());
    if (X509_CRL_verify(old.get(), X509_get0_pubkey(ca.get())) != 1)
      throw std::runtime_error("security revoke: " + crl_path.string() + " is not signed by identity_ca.pem");
    serials = x509::revoked_serials(old.get());
  }
  if (!name.empty()) {
    const fs::path cert_path = d / name / "cert.pem";
    if (name.find('/') != std::string::npos || !fs::is_regular_file(cert_path))
      throw std::runtime_error("security revoke: no identity '" + name + "' in '" + dir + "' (no " +
                               cert_path.string() + ")");
    const auto cert = x509::read_cert(cert_path.string());
    if (X509_check_issued(ca.get(), cert.get()) != X509_V_OK)
      throw std::runtime_error("security revoke: " + cert_path.string() + " was not issued by identity_ca.pem");
    const std::string serial = x509::serial_of(cert.get());
    if (std::find(serials.begin(), serials.end(), serial) != serials.end())
      throw std::runtime_error("security revoke: identity '" + name + "' is already revoked (serial " + serial + ")");
    serials.push_back(serial);
  }
  const auto crl = x509::make_crl(ca.get(), ca_key.get(), serials, x509::not_after_of(ca.get()));
  x509::write_crl(crl_path.string(), crl.get());
  return {crl_path.string()};
}

}  // namespace sensor_rig::dds
