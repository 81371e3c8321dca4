#pragma once
// Shared by the DDS Security process tests: what reached the mock ECU's bus, and a forged grant.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/can/candump.hpp"
#include "sensor_rig/dds/topic.hpp"
#include "sensor_rig/dds/types.hpp"

namespace sensor_rig::dbw::test {

// PU steering requests with the enable bit set (paravan_ref: 0x100, byte 1 bit 4), at or after t.
inline int enabled_requests(const std::string& bus_log, Nanos t) {
  std::ifstream in(bus_log);
  can::CandumpReader reader(in);
  can::LogRecord rec;
  int n = 0;
  while (reader.next(rec)) n += rec.frame.id == 0x100 && (rec.frame.data[1] & 0x10) != 0 && rec.stamp >= t ? 1 : 0;
  return n;
}

// A directory whose `reader` has the real identity (certificate and key from `real`) but
// permissions granting commands, signed by the permissions CA of another init (`rogue`, where
// `reader` was made a command source).
inline void forge(const std::filesystem::path& real, const std::filesystem::path& rogue,
                  const std::filesystem::path& out) {
  namespace fs = std::filesystem;
  fs::create_directories(out / "reader");
  const auto copy = [](const fs::path& from, const fs::path& to) {
    fs::copy_file(from, to, fs::copy_options::overwrite_existing);
  };
  copy(real / "identity_ca.pem", out / "identity_ca.pem");
  copy(real / "identity_crl.pem", out / "identity_crl.pem");
  copy(real / "reader/cert.pem", out / "reader/cert.pem");
  copy(real / "reader/key.pem", out / "reader/key.pem");
  copy(rogue / "permissions_ca.pem", out / "permissions_ca.pem");
  copy(rogue / "governance.p7s", out / "governance.p7s");
  copy(rogue / "reader/permissions.p7s", out / "reader/permissions.p7s");
}

// The bridge's last /diagnostics status ("dbw/bridge"): level, message and key/values, from what
// `reader` has received so far (empty values when none came).
struct BridgeDiagnostics {
  std::uint8_t level = 255;
  std::string message;
  std::map<std::string, std::string> values;
};
inline void take_bridge_diagnostics(const dds::Reader<msg::DiagnosticArray>& reader, BridgeDiagnostics& out) {
  reader.take([&](const msg::DiagnosticArray& a, const dds_sample_info_t&) {
    for (std::uint32_t i = 0; i < a.status._length; ++i) {
      const auto& st = a.status._buffer[i];
      if (std::string(st.name) != "dbw/bridge") continue;
      out.level = st.level;
      out.message = st.message;
      out.values.clear();
      for (std::uint32_t k = 0; k < st.values._length; ++k)
        out.values[st.values._buffer[k].key] = st.values._buffer[k].value;
    }
  }, 16);
}

}  // namespace sensor_rig::dbw::test
