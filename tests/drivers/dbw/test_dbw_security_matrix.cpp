// Issue 28, across real processes, for every `--cmd-protection` kind `rig security init` offers
// (none only with --no-unauthenticated: the rig refuses to make it otherwise): with two ordinary
// `rig monitor /vehicle/dbw/cmd` readers present (a writer then sends to the multicast address, which
// the secured bridge also hears), the mock ECU and `rig dbw bridge --security DIR` running, these
// senders all request engagement at once:
//   plain      an ordinary participant (no credentials)
//   ungranted  identity `reader`, authenticated, no grant (Cyclone refuses its writer: exit 1)
//   forged     `reader` with a grant signed by a permissions CA of its own
//   thief      `stolen`, a command source revoked (`rig security revoke`) after its files were
//              copied: it still holds its key, grant and the old, empty revocation list
//   revoked    `stolen` with the directory's current list (its own participant refuses: exit 1)
//   expired    `expired`, a command source whose certificate has expired (refused: exit 1)
//   loose key  `dbw_command` from a copy whose key.pem is 0644 (refused before DDS: exit 2)
// Not one command is counted by the bridge and not one enabled request reaches the bus; then the
// granted `dbw_command` drives. The test reads the bridge's status as identity `reader`.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "dbw_processes.hpp"
#include "dbw_security_processes.hpp"
#include "security_test_support.hpp"
#include "sensor_rig/dds/security.hpp"
#include "sensor_rig/drivers/dbw/dds_domain.hpp"
#include "sensor_rig/drivers/dbw/dds_types.hpp"
#include "wait_bounds.hpp"

namespace dbw = sensor_rig::dbw;
namespace msg = sensor_rig::msg;
namespace dds = sensor_rig::dds;
namespace fs = std::filesystem;
using sensor_rig::Nanos;
using sensor_rig::vehicle_now_ns;

namespace {

struct Kind {
  const char* name;
  bool no_unauthenticated;
};

class DbwSecurityMatrix : public ::testing::TestWithParam<Kind> {};

TEST_P(DbwSecurityMatrix, NoWriterWithoutAValidGrantReachesTheBus) {
  const Kind k = GetParam();
  dbw::test::RigProcesses rig(std::string("dbw_sec_matrix_") + k.name, dbw::test::DomainBy::kFlag);
  if (!rig.have_rig()) GTEST_SKIP() << "RIG_BIN not set or rig not built";
  const int domain = rig.domain();
  const std::string dom = std::to_string(domain);
  const auto run = [&](const std::string& name, const std::vector<std::string>& args) {
    const int rc = rig.wait_exit(rig.start(name, args), 15000);
    EXPECT_EQ(rc, 0) << rig.output(name);
    return rc == 0;
  };
  std::vector<std::string> flags{"--cmd-protection", k.name};
  if (k.no_unauthenticated) flags.emplace_back("--no-unauthenticated");
  const auto init = [&](const std::string& name, const std::string& dir, std::vector<std::string> extra) {
    std::vector<std::string> a{"security", "init", dir};
    a.insert(a.end(), flags.begin(), flags.end());
    a.insert(a.end(), extra.begin(), extra.end());
    return run(name, a);
  };
  const fs::path sec = rig.path("sec");
  if (k.no_unauthenticated) {  // the combination Cyclone 0.10.2 cannot enforce is not made
    EXPECT_EQ(rig.wait_exit(rig.start("init_open", {"security", "init", rig.path("open"), "--cmd-protection", k.name}),
                            15000),
              2);
    EXPECT_NE(rig.output("init_open").find("would let any participant without credentials drive"), std::string::npos)
        << rig.output("init_open");
    EXPECT_FALSE(fs::exists(fs::path(rig.path("open")) / "governance.p7s"));
  }
  ASSERT_TRUE(init("init", sec, {}));
  ASSERT_TRUE(run("add_stolen", {"security", "add-identity", sec, "stolen", "--permit-command"}));
  ASSERT_TRUE(run("add_expired", {"security", "add-identity", sec, "expired", "--permit-command"}));
  ASSERT_TRUE(init("init_rogue", rig.path("rogue"), {"--command", "reader", "--reader", "other"}));
  dbw::test::forge(sec, rig.path("rogue"), rig.path("forged"));
  fs::copy(sec, rig.path("thief"), fs::copy_options::recursive);  // before the revocation
  ASSERT_TRUE(run("revoke", {"security", "revoke", sec, "stolen"}));
  ASSERT_TRUE(dds::test::expire_certificate(sec, "expired"));
  fs::copy(sec, rig.path("loose"), fs::copy_options::recursive);
  ASSERT_EQ(::chmod((fs::path(rig.path("loose")) / "dbw_command/key.pem").c_str(), 0644), 0);

  // The bridge's status, read as `reader` (under --no-unauthenticated nothing else sees it).
  dds::Participant participant(sensor_rig::drivers::domain_config(domain), dds::security_files(sec, "reader"));
  dds::Topic<msg::DbwStatus> status_topic(participant, sensor_rig::drivers::kStatusTopic);
  dds::QosSpec deep;
  deep.depth = 64;
  dds::Reader<msg::DbwStatus> status(participant, status_topic, deep);
  dds::Topic<msg::DiagnosticArray> diag_topic(participant, "/diagnostics");
  dds::Reader<msg::DiagnosticArray> diagnostics(participant, diag_topic);
  bool engaged = false;
  unsigned long long counted = 0;
  const auto poll = [&](int ms) {
    const Nanos end = vehicle_now_ns() + static_cast<Nanos>(ms) * 1'000'000;
    while (vehicle_now_ns() < end) {
      status.wait(20);
      status.take([&](const msg::DbwStatus& s, const dds_sample_info_t&) {
        engaged = engaged || s.state == 1;
        counted = std::max<unsigned long long>(counted, s.commands);
      }, 64);
    }
  };

  const pid_t mock = rig.start_mock({"--duration", "60"});
  ASSERT_GT(mock, 0) << "mock ECU did not create its bus socket";
  const pid_t bridge = rig.start("bridge", {"dbw", "bridge", "--domain", dom, "--transport", rig.bus(), "--duration",
                                            "60", "--security", sec});
  ASSERT_TRUE(status.wait_for_writers(1, sensor_rig::test::kDiscoveryMs)) << rig.output("bridge");
  // Two ordinary readers of the command topic: the plain writer's samples then go to multicast.
  const pid_t mon1 = rig.start("mon1", {"monitor", "/vehicle/dbw/cmd", "--domain", dom, "--duration", "60"});
  const pid_t mon2 = rig.start("mon2", {"monitor", "/vehicle/dbw/cmd", "--domain", dom, "--duration", "60"});
  poll(2000);  // the monitors' readers discovered

  const auto send = [&](const std::string& name, const std::vector<std::string>& extra) {
    std::vector<std::string> a{"dbw", "send", "--domain", dom, "--enable", "--steer", "0.05", "--throttle", "0.2",
                               "--rate", "200", "--duration", "2"};
    a.insert(a.end(), extra.begin(), extra.end());
    return std::make_pair(name, rig.start(name, a));
  };
  const std::vector<std::pair<std::pair<std::string, pid_t>, int>> senders{
      {send("plain", {}), 0},
      {send("ungranted", {"--security", sec, "--identity", "reader"}), 1},
      {send("forged", {"--security", rig.path("forged"), "--identity", "reader"}), 0},
      {send("thief", {"--security", rig.path("thief"), "--identity", "stolen"}), 0},
      {send("revoked", {"--security", sec, "--identity", "stolen"}), 1},
      {send("expired", {"--security", sec, "--identity", "expired"}), 1},
      {send("loose_key", {"--security", rig.path("loose")}), 2},
  };
  for (const auto& [s, want] : senders) EXPECT_EQ(rig.wait_exit(s.second, 20000), want) << s.first << ":\n" << rig.output(s.first);
  EXPECT_NE(rig.output("plain").find("dbw send: 400 commands"), std::string::npos) << rig.output("plain");
  EXPECT_NE(rig.output("thief").find("dbw send: 400 commands"), std::string::npos) << rig.output("thief");
  EXPECT_NE(rig.output("loose_key").find("mode 0644"), std::string::npos) << rig.output("loose_key");
  EXPECT_NE(rig.output("expired").find("expired"), std::string::npos) << rig.output("expired");
  poll(500);
  EXPECT_FALSE(engaged) << "a sender without a valid grant engaged the bridge";
  EXPECT_EQ(counted, 0U) << "the bridge took commands from a sender without a valid grant";
  EXPECT_EQ(dbw::test::enabled_requests(rig.bus_log(), 0), 0) << "an enabled request reached the bus";

  // The granted source still drives, the monitors still there.
  const Nanos granted_start = vehicle_now_ns();
  const pid_t granted = send("granted", {"--security", sec}).second;
  EXPECT_EQ(rig.wait_exit(granted, 20000), 0) << rig.output("granted");
  poll(500);
  EXPECT_TRUE(engaged) << "the granted source did not engage\n" << rig.output("bridge");
  EXPECT_GT(counted, 100U);
  EXPECT_GT(dbw::test::enabled_requests(rig.bus_log(), granted_start), 10) << "no enabled request on the bus";
  // The bridge's identity expiry in /diagnostics: 365 days, nothing to warn about.
  dbw::test::BridgeDiagnostics diag;
  dbw::test::take_bridge_diagnostics(diagnostics, diag);
  EXPECT_EQ(diag.level, 0) << diag.message;
  EXPECT_EQ(diag.values["security_identity"], "dbw_bridge");
  EXPECT_TRUE(diag.values["security_days_left"] == "364" || diag.values["security_days_left"] == "365")
      << diag.values["security_days_left"];
  EXPECT_NE(diag.values["security_expires"].find("Z ("), std::string::npos) << diag.values["security_expires"];
  EXPECT_EQ(rig.stop(mon1), 0) << rig.output("mon1");
  EXPECT_EQ(rig.stop(mon2), 0) << rig.output("mon2");
  EXPECT_EQ(rig.stop(bridge), 0) << rig.output("bridge");
  EXPECT_EQ(rig.stop(mock), 0);
}

INSTANTIATE_TEST_SUITE_P(Kinds, DbwSecurityMatrix,
                         ::testing::Values(Kind{"none", true}, Kind{"sign", false}, Kind{"encrypt", false},
                                           Kind{"sign-origin", false}, Kind{"encrypt-origin", false}),
                         [](const ::testing::TestParamInfo<Kind>& i) {
                           std::string n = i.param.name;
                           for (auto& c : n)
                             if (c == '-') c = '_';
                           return n;
                         });

}  // namespace
