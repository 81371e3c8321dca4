// `rig record` in its own process against known publishers in this one: the file is read by
// @mcap/core and decoded with @foxglove/rosmsg2-serialization (tests/js/mcap_dump.mjs), and every
// sample must be there, byte-equal (FNV-1a of the payloads), with its stamps, source timestamp and
// QoS, for each compression; a topic of a type the rig does not know is reported and skipped; a
// SIGKILLed recorder leaves a readable prefix; a full disk stops the recording with the reason.
#include <gtest/gtest.h>

#include "record_support.hpp"
#include "sensor_rig/dds/cdr_view.hpp"
#include "sensor_rig/record/mcap_reader.hpp"

namespace sensor_rig::rig {
namespace {

constexpr dds_domainid_t kDomain = 48;
constexpr int kRounds = 30;

std::string profile() { return (test::source_dir() / "config/cyclonedds/loopback.xml").string(); }

class RecordEachCompression : public ::testing::TestWithParam<std::string> {};

TEST_P(RecordEachCompression, EverySampleByteEqualInMcapCore) {
  test::TempDir dir;
  const std::string file = (dir.path / "rec.mcap").string();
  const std::string prefix = "/test/rec/" + std::to_string(::getpid());
  test::RigChild rec({"record", "--out", file, "--domain", std::to_string(kDomain), "--dds-profile", profile(),
                      "--compression", GetParam(), "--chunk-kb", "64"},
                     (dir.path / "out").string(), (dir.path / "err").string());
  ASSERT_TRUE(rec.started());
  dds::Participant p(dds::DomainConfig{kDomain, profile()});
  test::KnownPublishers pubs(p, prefix);
  ASSERT_TRUE(pubs.wait_for_readers(1)) << rec.err();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // /rig/stamps' reader too
  for (int i = 0; i < kRounds; ++i) {
    pubs.publish(i);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ASSERT_EQ(rec.signal_and_wait(SIGINT, 20'000), 0) << rec.err();

  const auto summary = rec.summary();
  ASSERT_FALSE(summary.is_discarded()) << rec.out() << rec.err();
  for (const auto& t : pubs.topics()) {
    SCOPED_TRACE(t);
    EXPECT_EQ(summary["topics"][t]["received"], kRounds);
    EXPECT_EQ(summary["topics"][t]["written"], kRounds);
  }
  EXPECT_EQ(summary["drops"]["queue_full"], 0);
  EXPECT_EQ(summary["drops"]["disk"], 0);
  EXPECT_NE(rec.err().find("MB/s"), std::string::npos) << "no progress line: " << rec.err();

  const auto j = test::mcap_dump(file);
  ASSERT_FALSE(j.contains("error")) << j.dump();
  EXPECT_EQ(j["profile"], "ros2");
  EXPECT_EQ(j["undecodable"], 0);
  EXPECT_EQ(j["stream_complete"], true);
  EXPECT_EQ(j["streamed"], kRounds * 6);
  EXPECT_EQ(j["channels"][prefix + "/points"]["schema"], "sensor_msgs/msg/PointCloud2");
  EXPECT_EQ(j["channels"]["/rig/stamps"]["schema"], "sensor_rig_msgs/msg/SourceStamps");
  EXPECT_EQ(j["channels"]["/diagnostics"]["schema"], "diagnostic_msgs/msg/DiagnosticArray");
  const std::string qos_reliable = j["channels"][prefix + "/points"]["metadata"]["offered_qos_profiles"];
  EXPECT_NE(qos_reliable.find("reliability: 1"), std::string::npos) << qos_reliable;
  EXPECT_NE(qos_reliable.find("depth: 64"), std::string::npos) << qos_reliable;
  const std::string qos_be = j["channels"][prefix + "/image_raw/compressed"]["metadata"]["offered_qos_profiles"];
  EXPECT_NE(qos_be.find("reliability: 2"), std::string::npos) << qos_be;

  std::map<std::string, int> seen;
  for (const auto& m : j["messages"]) {
    const std::string topic = m["topic"];
    const int k = seen[topic]++;
    ASSERT_LT(k, kRounds) << topic;
    const auto& want = pubs.truth[topic][static_cast<std::size_t>(k)];
    SCOPED_TRACE(topic + " #" + std::to_string(k));
    EXPECT_EQ(m["stamp_ns"], std::to_string(want.stamp_ns));
    EXPECT_EQ(m["sequence"], k);
    EXPECT_GE(std::stoll(m["log_time"].get<std::string>()), std::stoll(m["publish_time"].get<std::string>()) - 1'000'000);
    if (topic != "/rig/stamps") {
      EXPECT_EQ(m["publish_time"], std::to_string(want.publish_ns));
    }
    if (want.fnv != 0) {
      EXPECT_EQ(m["data_fnv"], want.fnv);
    }
    if (topic == prefix + "/points") {
      EXPECT_EQ(m["width"], want.width);
    }
    if (topic == prefix + "/camera_info") {
      EXPECT_EQ(m["k"][8], 8 + k);
    }
    if (topic == "/diagnostics") {
      EXPECT_EQ(m["status"][0]["name"], "test: node");
    }
    if (topic == "/rig/stamps") {
      EXPECT_EQ(m["seq"], std::to_string(k));
    }
  }
  for (const auto& t : pubs.topics()) EXPECT_EQ(seen[t], kRounds) << t;
}

INSTANTIATE_TEST_SUITE_P(All, RecordEachCompression, ::testing::Values("none", "lz4", "zstd"));

TEST(Record, AnUnknownTypeIsReportedAndSkipped) {
  test::TempDir dir;
  const std::string file = (dir.path / "rec.mcap").string();
  const std::string prefix = "/test/rec_unknown/" + std::to_string(::getpid());
  test::RigChild rec({"record", "--out", file, "--domain", std::to_string(kDomain), "--dds-profile", profile()},
                     (dir.path / "out").string(), (dir.path / "err").string());
  dds::Participant p(dds::DomainConfig{kDomain, profile()});
  // NavSatStatus's layout under a name no registry entry has.
  dds_topic_descriptor_t desc = sensor_msgs_msg_dds__NavSatStatus__desc;
  desc.m_typename = "test_msgs::msg::dds_::Unknown_";
  const dds::Entity topic(dds::check(dds_create_topic(p.handle(), &desc, ("rt" + prefix + "/odd").c_str(), nullptr, nullptr), "topic"));
  const dds::Entity writer(dds::check(dds_create_writer(p.handle(), topic.handle(), nullptr, nullptr), "writer"));
  test::KnownPublishers pubs(p, prefix);
  ASSERT_TRUE(pubs.wait_for_readers(1)) << rec.err();
  sensor_msgs_msg_dds__NavSatStatus_ st{3, 4};
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(dds_write(writer.handle(), &st), DDS_RETCODE_OK);
    pubs.publish(i);
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  ASSERT_EQ(rec.signal_and_wait(SIGTERM, 20'000), 0) << rec.err();
  const auto summary = rec.summary();
  ASSERT_FALSE(summary.is_discarded()) << rec.out();
  const std::string why = summary["skipped"][prefix + "/odd"];
  EXPECT_NE(why.find("test_msgs::msg::dds_::Unknown_"), std::string::npos) << why;
  EXPECT_NE(rec.err().find(prefix + "/odd: not recorded"), std::string::npos) << rec.err();
  EXPECT_EQ(summary["topics"][prefix + "/points"]["written"], 5);
  const auto j = test::mcap_dump(file);
  ASSERT_FALSE(j.contains("error")) << j.dump();
  EXPECT_FALSE(j["channels"].contains(prefix + "/odd"));
}

TEST(Record, AKilledRecorderLeavesEveryCompletedChunkReadable) {
  test::TempDir dir;
  const std::string file = (dir.path / "rec.mcap").string();
  const std::string prefix = "/test/rec_kill/" + std::to_string(::getpid());
  test::RigChild rec({"record", prefix + "/points", "--out", file, "--domain", std::to_string(kDomain), "--dds-profile",
                      profile(), "--compression", "lz4", "--chunk-kb", "32"},
                     (dir.path / "out").string(), (dir.path / "err").string());
  dds::Participant p(dds::DomainConfig{kDomain, profile()});
  test::KnownPublishers pubs(p, prefix);
  ASSERT_TRUE(pubs.wait_for_points_reader(1)) << rec.err();
  constexpr int kN = 100;
  for (int i = 0; i < kN; ++i) {
    pubs.publish(i, 1000);  // ~16 KB clouds: two per chunk
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_EQ(rec.signal_and_wait(SIGKILL, 5000), 128 + SIGKILL);

  record::McapReader r(file);
  EXPECT_FALSE(r.complete());
  ASSERT_FALSE(r.problems().empty());
  EXPECT_NE(r.problems()[0].what.find("truncated"), std::string::npos) << r.problems()[0].what;
  int n = 0;
  r.for_each_message([&](const record::McapMessage& m) {
    const auto& want = pubs.truth[prefix + "/points"][m.sequence];
    const auto body = dds::cdr_body(m.data);
    dds::PointCloud2View v;
    EXPECT_TRUE(body && dds::parse_cdr(*body, v) == dds::CdrStatus::kOk);
    EXPECT_EQ(v.width, want.width);
    EXPECT_EQ(test::fnv1a_bytes(v.data.data(), v.data.size()), want.fnv);
    EXPECT_EQ(m.sequence, static_cast<std::uint32_t>(n));
    ++n;
    return true;
  });
  // Everything but the chunk being filled (at most 32 KiB: two clouds) is there.
  EXPECT_GE(n, kN - 3);
  EXPECT_LE(n, kN);
  // @mcap/core's indexed reader needs the summary a killed recorder never wrote: it refuses the
  // file, and our reader (above, and `rig play`) is the recovery path.
}

TEST(Record, AFullDiskStopsWithTheReason) {
  test::TempDir dir;
  test::RigChild rec({"record", "--out", "/dev/full", "--domain", std::to_string(kDomain), "--dds-profile", profile()},
                     (dir.path / "out").string(), (dir.path / "err").string());
  EXPECT_EQ(rec.wait(20'000), 1);
  EXPECT_NE(rec.err().find("No space left on device"), std::string::npos) << rec.err();
}

TEST(Record, BadUsageIsExit2) {
  test::TempDir dir;
  test::RigChild a({"record", "--out", dir.path.string()}, (dir.path / "o1").string(), (dir.path / "e1").string());
  EXPECT_EQ(a.wait(20'000), 2);
  EXPECT_NE(a.err().find("is a folder"), std::string::npos) << a.err();
  test::RigChild b({"record", "--out", "x.mcap", "--compression", "brotli"}, (dir.path / "o2").string(), (dir.path / "e2").string());
  EXPECT_EQ(b.wait(20'000), 2);
  test::RigChild c({"record", "--out", dir.path.string(), "--split-mb", "10"}, (dir.path / "o3").string(), (dir.path / "e3").string());
  EXPECT_EQ(c.wait(20'000), 2);  // not empty: o1, e1, ...
  EXPECT_NE(c.err().find("not an empty folder"), std::string::npos) << c.err();
}

}  // namespace
}  // namespace sensor_rig::rig
