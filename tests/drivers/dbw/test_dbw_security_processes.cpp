// Issue 13, "only the permitted source may drive", across real processes: `rig security init`
// makes a directory; `rig mock paravan` and `rig dbw bridge --security DIR` (identity dbw_bridge)
// run; then, while no one else sends:
//  1. a sender without credentials (an ordinary participant) with --enable,
//  2. a sender with a valid identity (`reader`) carrying forged write permissions (signed by a
//     permissions CA of its own: Cyclone accepts them locally, the bridge must refuse them),
//  3. `reader` with its real permissions, and `logger`, added later by `rig security add-identity`
//     without --permit-command (Cyclone refuses their writers: exit 1 naming the grant);
// none engages or is counted by the bridge, and the bus holds no enabled request; then
//  4. the permitted `dbw_command` engages: enabled requests on the bus; then
//  5. `planner`, added later with --permit-command (signed by the same CA, every other identity
//     unchanged), drives too: the bridge counts its commands; in all it counted at most what these
//     two sent (nothing from 1 and 2, which each sent more).
// And credentials Cyclone refuses (a grant changed after signing, another identity's certificate,
// no plugins) end `rig dbw send` with the reason instead of an ordinary participant.
// The test's own participant is an ordinary one: the bridge's status stays readable without
// credentials (allow_unauthenticated_participants).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "dbw_processes.hpp"
#include "dbw_security_processes.hpp"
#include "dbw_test_data.hpp"
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

// The number in "key":N of the bridge's JSON summary; -1 when absent.
long long json_number(const std::string& text, const std::string& key) {
  std::smatch m;
  if (!std::regex_search(text, m, std::regex("\"" + key + "\":([0-9]+)"))) return -1;
  return std::stoll(m[1]);
}

TEST(DbwSecurityProcesses, OnlyThePermittedSourceDrives) {
  dbw::test::RigProcesses rig("dbw_security", dbw::test::DomainBy::kFlag);
  if (!rig.have_rig()) GTEST_SKIP() << "RIG_BIN not set or rig not built";
  const std::string dom = std::to_string(rig.domain());
  const std::string sec = rig.path("sec");
  ASSERT_EQ(rig.wait_exit(rig.start("init", {"security", "init", sec}), 10000), 0) << rig.output("init");
  ASSERT_EQ(rig.wait_exit(rig.start("init_rogue", {"security", "init", rig.path("rogue"), "--command", "reader",
                                                   "--reader", "other"}),
                          10000),
            0)
      << rig.output("init_rogue");
  dbw::test::forge(sec, rig.path("rogue"), rig.path("forged"));
  // Identities added after the bridge's were made: one command source, one without the grant.
  ASSERT_EQ(rig.wait_exit(rig.start("add_planner", {"security", "add-identity", sec, "planner", "--permit-command"}),
                          10000),
            0)
      << rig.output("add_planner");
  ASSERT_EQ(rig.wait_exit(rig.start("add_logger", {"security", "add-identity", sec, "logger"}), 10000), 0)
      << rig.output("add_logger");
  EXPECT_EQ(rig.wait_exit(rig.start("add_again", {"security", "add-identity", sec, "logger"}), 10000), 2);
  EXPECT_NE(rig.output("add_again").find("identity 'logger' already exists"), std::string::npos)
      << rig.output("add_again");
  EXPECT_EQ(rig.wait_exit(rig.start("add_no_ca", {"security", "add-identity", rig.path("no_ca"), "x"}), 10000), 2);
  EXPECT_NE(rig.output("add_no_ca").find("holds no complete CA"), std::string::npos) << rig.output("add_no_ca");

  dds::Participant participant(sensor_rig::drivers::domain_config(rig.domain()));  // no credentials
  dds::Topic<msg::DbwStatus> status_topic(participant, sensor_rig::drivers::kStatusTopic);
  dds::QosSpec deep;
  deep.depth = 64;
  dds::Reader<msg::DbwStatus> status(participant, status_topic, deep);
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

  const pid_t mock = rig.start_mock({"--duration", "30"});
  ASSERT_GT(mock, 0) << "mock ECU did not create its bus socket";
  const pid_t bridge = rig.start("bridge", {"dbw", "bridge", "--domain", dom, "--transport", rig.bus(), "--duration",
                                            "30", "--security", sec});
  ASSERT_TRUE(status.wait_for_writers(1, sensor_rig::test::kDiscoveryMs)) << "secured bridge's status not readable without credentials\n"
                                                 << rig.output("bridge");
  const auto send = [&](const std::string& name, std::vector<std::string> extra) {
    std::vector<std::string> a{"dbw", "send", "--domain", dom, "--enable", "--steer", "0.05", "--throttle", "0.2",
                               "--rate", "200", "--duration", "1.5"};
    a.insert(a.end(), extra.begin(), extra.end());
    return rig.start(name, a);
  };

  // 1-3 at once: none may engage.
  const pid_t plain = send("plain", {});
  const pid_t forged = send("forged", {"--security", rig.path("forged"), "--identity", "reader"});
  const pid_t reader = send("reader", {"--security", sec, "--identity", "reader"});
  const pid_t logger = send("logger", {"--security", sec, "--identity", "logger"});
  EXPECT_EQ(rig.wait_exit(reader, 10000), 1) << rig.output("reader");
  EXPECT_NE(rig.output("reader").find("identity 'reader' may not publish /vehicle/dbw/cmd"), std::string::npos)
      << rig.output("reader");
  EXPECT_EQ(rig.wait_exit(logger, 10000), 1) << rig.output("logger");
  EXPECT_NE(rig.output("logger").find("identity 'logger' may not publish /vehicle/dbw/cmd"), std::string::npos)
      << rig.output("logger");
  EXPECT_EQ(rig.wait_exit(plain, 10000), 0) << rig.output("plain");
  EXPECT_EQ(rig.wait_exit(forged, 10000), 0) << rig.output("forged");
  EXPECT_NE(rig.output("plain").find("dbw send: 300 commands"), std::string::npos) << rig.output("plain");
  EXPECT_NE(rig.output("forged").find("dbw send: 300 commands"), std::string::npos) << rig.output("forged");
  poll(300);
  // Only this test's bridge writes the status in its domain: another test's bridge would be read as
  // this one (CI once ran two dbw tests in one domain when domains were derived from the pid).
  ASSERT_EQ(status.matched(), 1U) << "more than one /vehicle/dbw/status writer in domain " << dom;
  EXPECT_FALSE(engaged) << "a sender without permission engaged the bridge";
  EXPECT_EQ(counted, 0U) << "the bridge took commands from a sender without permission";
  EXPECT_EQ(dbw::test::enabled_requests(rig.bus_log(), 0), 0) << "an enabled request reached the bus";

  // 4. The permitted source drives.
  const Nanos permitted_start = vehicle_now_ns();
  const pid_t permitted = send("permitted", {"--security", sec});
  EXPECT_EQ(rig.wait_exit(permitted, 10000), 0) << rig.output("permitted");
  poll(300);
  EXPECT_TRUE(engaged) << "the permitted source did not engage\n" << rig.output("bridge");
  EXPECT_GT(counted, 0U);
  EXPECT_GT(dbw::test::enabled_requests(rig.bus_log(), permitted_start), 10) << "no enabled request on the bus";

  // 5. The command source added later drives too.
  const unsigned long long before_added = counted;
  const Nanos added_start = vehicle_now_ns();
  const pid_t added = send("planner", {"--security", sec, "--identity", "planner"});
  EXPECT_EQ(rig.wait_exit(added, 10000), 0) << rig.output("planner");
  poll(300);
  EXPECT_GT(counted, before_added + 10) << "the bridge took no commands from the added identity\n" << rig.output("bridge");
  EXPECT_GT(dbw::test::enabled_requests(rig.bus_log(), added_start), 10) << "no enabled request from the added identity";
  EXPECT_EQ(rig.stop(bridge), 0) << rig.output("bridge");
  EXPECT_EQ(rig.stop(mock), 0);
  const long long taken = json_number(rig.output("bridge"), "commands");
  // The permitted senders' 2 x 300, less what late matches lost; anything above came from 1 or 2.
  EXPECT_GT(taken, 0) << rig.output("bridge");
  EXPECT_LE(taken, 600) << "the bridge counted commands beyond the permitted senders' 600";
}

}  // namespace

namespace {

// Credentials Cyclone refuses, and plugins that are not there: `rig dbw send` exits 1 saying so
// (no participant, nothing sent), instead of running as an ordinary participant.
TEST(DbwSecurityProcesses, RefusedCredentialsAndMissingPluginsAreReported) {
  dbw::test::RigProcesses rig("dbw_security_refused", dbw::test::DomainBy::kFlag);
  if (!rig.have_rig()) GTEST_SKIP() << "RIG_BIN not set or rig not built";
  const std::string sec = rig.path("sec");
  ASSERT_EQ(rig.wait_exit(rig.start("init", {"security", "init", sec}), 10000), 0) << rig.output("init");
  const auto send = [&](const std::string& name, const std::string& dir) {
    return rig.wait_exit(rig.start(name, {"dbw", "send", "--domain", std::to_string(rig.domain()), "--rate", "10",
                                          "--duration", "0.2", "--security", dir}),
                         10000);
  };
  // A grant changed after signing.
  const fs::path tampered = rig.path("tampered");
  fs::copy(sec, tampered, fs::copy_options::recursive);
  std::string perms = dbw::test::read_text(tampered / "dbw_command/permissions.p7s");
  const std::string grant = "<topic>rt/vehicle/dbw/cmd</topic>";
  perms.replace(perms.find(grant), grant.size(), "<topic>rt/vehicle/dbw/*</topic>");
  std::ofstream(tampered / "dbw_command/permissions.p7s", std::ios::trunc) << perms;
  EXPECT_EQ(send("tampered", tampered.string()), 1);
  EXPECT_NE(rig.output("tampered").find("participant with identity 'dbw_command'"), std::string::npos)
      << rig.output("tampered");
  EXPECT_NE(rig.output("tampered").find("signature failure"), std::string::npos) << rig.output("tampered");
  EXPECT_EQ(rig.output("tampered").find("dbw send:"), std::string::npos) << "it sent";
  // Another identity's certificate under dbw_command's grant.
  const fs::path swapped = rig.path("swapped");
  fs::copy(sec, swapped, fs::copy_options::recursive);
  fs::copy_file(fs::path(sec) / "reader/cert.pem", swapped / "dbw_command/cert.pem", fs::copy_options::overwrite_existing);
  fs::copy_file(fs::path(sec) / "reader/key.pem", swapped / "dbw_command/key.pem", fs::copy_options::overwrite_existing);
  EXPECT_EQ(send("swapped", swapped.string()), 1);
  EXPECT_NE(rig.output("swapped").find("Subject name is invalid"), std::string::npos) << rig.output("swapped");
  // No plugins where they are looked for.
  ::setenv("RIG_DDS_SECURITY_PLUGINS", rig.path("no_plugins").c_str(), 1);
  const int rc = send("no_plugins", sec);
  ::unsetenv("RIG_DDS_SECURITY_PLUGINS");
  EXPECT_EQ(rc, 1);
  EXPECT_NE(rig.output("no_plugins").find("plugin libdds_security_auth.so not found"), std::string::npos)
      << rig.output("no_plugins");
  // A directory without the identity: a usage error before anything starts.
  EXPECT_EQ(send("missing", rig.path("nothing_here")), 2);
  EXPECT_NE(rig.output("missing").find("missing"), std::string::npos) << rig.output("missing");
}

}  // namespace
