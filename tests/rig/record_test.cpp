// `rig record` in its own process against known publishers in this one: the file is read by
// @mcap/core and decoded with @foxglove/rosmsg2-serialization (tests/js/mcap_dump.mjs), and every
// sample must be there, byte-equal (FNV-1a of the payloads), with its stamps, source timestamp and
// QoS, for each compression; a topic of a type the rig does not know is reported and skipped; a
// SIGKILLed recorder leaves a readable prefix; a full disk stops the recording with the reason. A
// split recording's metadata.yaml (parsed by yaml-cpp) names each file with the counts @mcap/core
// reads in it, after SIGINT and after SIGKILL; `rig record repair` makes the killed file a complete
// indexed one that @mcap/core's indexed reader takes, with exactly what its stream reader finds
// intact in the broken file.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>

#include "dds_domain_lease.hpp"
#include "record_support.hpp"
#include "sensor_rig/dds/cdr_view.hpp"
#include "sensor_rig/record/mcap_reader.hpp"

namespace sensor_rig::rig {
namespace {

// Leased (tests/support/dds_domain_lease.hpp): no other test on the host shares it.
const dds_domainid_t kDomain = static_cast<dds_domainid_t>(sensor_rig::test::lease_dds_domain());
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

// tests/js/mcap_messages.mjs: every message as @mcap/core's indexed or stream reader has it.
nlohmann::json node_messages(const std::string& file, const char* mode) {
  const auto script = test::source_dir() / "tests/js/mcap_messages.mjs";
  const auto [rc, out] = test::run("node " + script.string() + " " + file + " " + mode + " 2>&1");
  auto j = nlohmann::json::parse(out, nullptr, false);
  if (rc != 0 || j.is_discarded()) return nlohmann::json{{"error", "exit " + std::to_string(rc) + ": " + out}};
  return j;
}

std::vector<std::string> mcap_files_in(const std::filesystem::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.path().extension() == ".mcap") names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end(), [](const std::string& a, const std::string& b) {
    return a.size() != b.size() ? a.size() < b.size() : a < b;  // rec_2 before rec_10
  });
  return names;
}

// metadata.yaml's files: each one's count and times against @mcap/core's indexed reader; returns the
// per-topic counts summed over them.
std::map<std::string, std::uint64_t> check_metadata_files(const std::filesystem::path& dir, const YAML::Node& m,
                                                         const std::vector<std::string>& expect_files) {
  std::map<std::string, std::uint64_t> per_topic;
  EXPECT_EQ(m["version"].as<int>(), 5);
  EXPECT_EQ(m["storage_identifier"].as<std::string>(), "mcap");
  EXPECT_EQ(m["compression_format"].as<std::string>(), "");
  EXPECT_EQ(m["compression_mode"].as<std::string>(), "");
  EXPECT_EQ(m["relative_file_paths"].as<std::vector<std::string>>(), expect_files);
  if (m["files"].size() != expect_files.size()) {
    ADD_FAILURE() << "files: " << m["files"].size() << " entries, " << expect_files.size() << " expected";
    return per_topic;
  }
  std::uint64_t total = 0, first = UINT64_MAX, last = 0;
  for (std::size_t f = 0; f < expect_files.size(); ++f) {
    SCOPED_TRACE(expect_files[f]);
    const YAML::Node fi = m["files"][f];
    EXPECT_EQ(fi["path"].as<std::string>(), expect_files[f]);
    const auto j = node_messages((dir / expect_files[f]).string(), "indexed");
    if (j.contains("error")) {
      ADD_FAILURE() << j.dump();
      continue;
    }
    EXPECT_EQ(fi["message_count"].as<std::uint64_t>(), j["count"].get<std::uint64_t>());
    const std::uint64_t start = std::stoull(j["statistics"]["message_start"].get<std::string>());
    const std::uint64_t end = std::stoull(j["statistics"]["message_end"].get<std::string>());
    EXPECT_EQ(fi["starting_time"]["nanoseconds_since_epoch"].as<std::uint64_t>(), start);
    EXPECT_EQ(fi["duration"]["nanoseconds"].as<std::uint64_t>(), end - start);
    total += j["count"].get<std::uint64_t>();
    first = std::min(first, start);
    last = std::max(last, end);
    for (const auto& [t, n] : j["per_topic"].items()) per_topic[t] += n.get<std::uint64_t>();
  }
  EXPECT_EQ(m["message_count"].as<std::uint64_t>(), total);
  EXPECT_EQ(m["starting_time"]["nanoseconds_since_epoch"].as<std::uint64_t>(), first);
  EXPECT_EQ(m["duration"]["nanoseconds"].as<std::uint64_t>(), last - first);
  for (const auto& t : m["topics_with_message_count"]) {
    const std::string name = t["topic_metadata"]["name"].as<std::string>();
    EXPECT_EQ(t["message_count"].as<std::uint64_t>(), per_topic[name]) << name;
    EXPECT_EQ(t["topic_metadata"]["serialization_format"].as<std::string>(), "cdr");
  }
  EXPECT_EQ(m["topics_with_message_count"].size(), per_topic.size());
  return per_topic;
}

TEST(Record, ASplitRecordingStoppedBySigintHasRosbag2sMetadataYaml) {
  test::TempDir dir;
  const auto folder = dir.path / "drive";
  const std::string prefix = "/test/rec_meta/" + std::to_string(::getpid());
  test::RigChild rec({"record", "--out", folder.string(), "--domain", std::to_string(kDomain), "--dds-profile",
                      profile(), "--split-s", "1"},
                     (dir.path / "out").string(), (dir.path / "err").string());
  ASSERT_TRUE(rec.started());
  dds::Participant p(dds::DomainConfig{kDomain, profile()});
  test::KnownPublishers pubs(p, prefix);
  ASSERT_TRUE(pubs.wait_for_readers(1)) << rec.err();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  constexpr int kN = 35;  // 100 ms apart: 3.5 s of log time, 4 files
  for (int i = 0; i < kN; ++i) {
    pubs.publish(i);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ASSERT_EQ(rec.signal_and_wait(SIGINT, 20'000), 0) << rec.err();

  const auto files = mcap_files_in(folder);
  ASSERT_GE(files.size(), 3u);
  EXPECT_EQ(files[0], "drive_0.mcap");
  const YAML::Node m = YAML::LoadFile((folder / "metadata.yaml").string())["rosbag2_bagfile_information"];
  ASSERT_TRUE(m.IsMap());
  const auto per_topic = check_metadata_files(folder, m, files);
  const auto dump = test::mcap_dump((folder / files[0]).string());  // the channels' QoS and types, as @mcap/core has them
  ASSERT_FALSE(dump.contains("error")) << dump.dump();
  for (const auto& t : pubs.topics()) EXPECT_EQ(per_topic.at(t), static_cast<std::uint64_t>(kN)) << t;
  for (const auto& t : m["topics_with_message_count"]) {
    const std::string name = t["topic_metadata"]["name"].as<std::string>();
    if (!dump["channels"].contains(name)) continue;
    EXPECT_EQ(t["topic_metadata"]["type"].as<std::string>(), dump["channels"][name]["schema"]) << name;
    EXPECT_EQ(t["topic_metadata"]["offered_qos_profiles"].as<std::string>(),
              dump["channels"][name]["metadata"]["offered_qos_profiles"]) << name;
  }
}

// SIGKILL mid-run: metadata.yaml lists every file closed before the kill (not the one being
// written); `rig record repair` makes that one complete and indexed with every intact chunk.
TEST(Record, AKilledSplitRecordingIsListedAndItsLastFileRepaired) {
  test::TempDir dir;
  const auto folder = dir.path / "drive";
  const std::string prefix = "/test/rec_repair/" + std::to_string(::getpid());
  test::RigChild rec({"record", prefix + "/points", "--out", folder.string(), "--domain", std::to_string(kDomain),
                      "--dds-profile", profile(), "--split-s", "1", "--compression", "lz4", "--chunk-kb", "32"},
                     (dir.path / "out").string(), (dir.path / "err").string());
  dds::Participant p(dds::DomainConfig{kDomain, profile()});
  test::KnownPublishers pubs(p, prefix);
  ASSERT_TRUE(pubs.wait_for_points_reader(1)) << rec.err();
  constexpr int kN = 100;
  for (int i = 0; i < kN; ++i) {
    pubs.publish(i, 1000);  // ~16 KB clouds: two per chunk; 25 ms apart: 2.5 s, 3 files
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_EQ(rec.signal_and_wait(SIGKILL, 5000), 128 + SIGKILL);

  auto files = mcap_files_in(folder);
  ASSERT_GE(files.size(), 2u);
  const std::string broken = (folder / files.back()).string();
  files.pop_back();
  const YAML::Node m = YAML::LoadFile((folder / "metadata.yaml").string())["rosbag2_bagfile_information"];
  ASSERT_TRUE(m.IsMap());
  const auto listed = check_metadata_files(folder, m, files);  // every file but the killed one

  const auto truth = node_messages(broken, "stream");  // what is intact in it, by @mcap/core's stream reader
  ASSERT_FALSE(truth.contains("error")) << truth.dump();
  EXPECT_NE(truth["stopped"], "");
  EXPECT_TRUE(node_messages(broken, "indexed").contains("error"));  // no summary: refused
  const std::string fixed = (dir.path / "fixed.mcap").string();
  test::RigChild repair({"record", "repair", broken, "--out", fixed}, (dir.path / "rout").string(),
                        (dir.path / "rerr").string());
  ASSERT_EQ(repair.wait(60'000), 0) << repair.err();
  // Chunks are written whole: the file ends at a record boundary (or inside one, cut by the kernel).
  EXPECT_TRUE(repair.err().find("without DataEnd") != std::string::npos ||
              repair.err().find("runs past the end of the file") != std::string::npos)
      << repair.err();
  const auto summary = repair.summary();
  ASSERT_FALSE(summary.is_discarded()) << repair.out();
  EXPECT_EQ(summary["messages"], truth["count"]);
  EXPECT_EQ(summary["cut"], true);

  const auto got = node_messages(fixed, "indexed");
  ASSERT_FALSE(got.contains("error")) << got.dump();
  ASSERT_EQ(got["count"], truth["count"]);
  EXPECT_EQ(got["messages"], truth["messages"]);  // same messages, same bytes (FNV-1a of each)
  const auto dump = test::mcap_dump(fixed);      // decoded: the clouds the test published
  ASSERT_FALSE(dump.contains("error")) << dump.dump();
  for (const auto& msg : dump["messages"]) {
    const auto seq = msg["sequence"].get<std::size_t>();
    ASSERT_LT(seq, pubs.truth[prefix + "/points"].size());
    const auto& want = pubs.truth[prefix + "/points"][seq];
    EXPECT_EQ(msg["width"], want.width) << seq;
    EXPECT_EQ(msg["data_fnv"], want.fnv) << seq;
  }
  // Listed files + the repaired one: all but the chunk being filled at the kill (<= 32 KiB: 2 clouds).
  const auto total = listed.count(prefix + "/points") ? listed.at(prefix + "/points") : 0;
  EXPECT_GE(total + got["count"].get<std::uint64_t>(), static_cast<std::uint64_t>(kN - 3));

  // Without --out: in place, the original kept beside it as IN.broken.
  test::RigChild again({"record", "repair", broken}, (dir.path / "rout2").string(), (dir.path / "rerr2").string());
  ASSERT_EQ(again.wait(60'000), 0) << again.err();
  EXPECT_TRUE(std::filesystem::exists(broken + ".broken"));
  EXPECT_EQ(node_messages(broken, "indexed")["messages"], truth["messages"]);
  // Repaired in its folder, the file is in metadata.yaml now: every file named, each with the count
  // and times @mcap/core's indexed reader finds in it, the topics' counts and the totals over all.
  const YAML::Node m2 = YAML::LoadFile((folder / "metadata.yaml").string())["rosbag2_bagfile_information"];
  ASSERT_TRUE(m2.IsMap());
  auto all = files;
  all.push_back(std::filesystem::path(broken).filename().string());
  const auto per_topic = check_metadata_files(folder, m2, all);
  EXPECT_EQ(per_topic.at(prefix + "/points"), total + got["count"].get<std::uint64_t>());
  const auto again_summary = again.summary();
  EXPECT_EQ(again_summary["metadata_files"].get<std::vector<std::string>>(), all) << again.out();
  const auto qos = test::mcap_dump(broken)["channels"][prefix + "/points"]["metadata"]["offered_qos_profiles"];
  for (const auto& t : m2["topics_with_message_count"]) {
    EXPECT_EQ(t["topic_metadata"]["type"].as<std::string>(), "sensor_msgs/msg/PointCloud2");
    EXPECT_EQ(t["topic_metadata"]["offered_qos_profiles"].as<std::string>(), qos.get<std::string>());
  }
}

TEST(Record, RepairOfWhatIsNotMcapIsARuntimeError) {
  test::TempDir dir;
  const auto bad = dir.write("bad.mcap", "not an mcap file at all, not at all");
  test::RigChild r({"record", "repair", bad, "--out", (dir.path / "o.mcap").string()}, (dir.path / "out").string(),
                   (dir.path / "err").string());
  EXPECT_EQ(r.wait(20'000), 1);
  EXPECT_NE(r.err().find("wrong magic at offset 0"), std::string::npos) << r.err();
  EXPECT_FALSE(std::filesystem::exists(dir.path / "o.mcap"));
}

}  // namespace
}  // namespace sensor_rig::rig
