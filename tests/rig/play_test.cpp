// `rig play` in its own process, read back by typed readers here: a recording made by `rig record`
// of known publishers plays with every sample byte-equal, the QoS recorded and the recorded timing
// (lateness measured by the player); a file written by @mcap/core's McapWriter (tests/js/
// mcap_make.mjs) plays its known type and refuses the unknown one with the reason; a cut file,
// a corrupt chunk and wrong magic are errors naming the offset, and what is intact plays.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "record_support.hpp"
#include "sensor_rig/dds/discovery.hpp"
#include "sensor_rig/record/mcap_reader.hpp"

namespace sensor_rig::rig {
namespace {

constexpr dds_domainid_t kRecordDomain = 48;
constexpr dds_domainid_t kPlayDomain = 49;
constexpr int kRounds = 30;

std::string profile() { return (test::source_dir() / "config/cyclonedds/loopback.xml").string(); }

// A recording of KnownPublishers (kRounds rounds 20 ms apart) and its ground truth.
struct Recording {
  std::string file;
  std::map<std::string, std::vector<test::Truth>> truth;
  std::string prefix;
};

Recording make_recording(const test::TempDir& dir) {
  Recording r;
  r.file = (dir.path / "rec.mcap").string();
  r.prefix = "/test/play/" + std::to_string(::getpid());
  test::RigChild rec({"record", "--out", r.file, "--domain", std::to_string(kRecordDomain), "--dds-profile", profile(),
                      "--compression", "zstd", "--chunk-kb", "32", "--no-progress"},
                     (dir.path / "rec_out").string(), (dir.path / "rec_err").string());
  dds::Participant p(dds::DomainConfig{kRecordDomain, profile()});
  test::KnownPublishers pubs(p, r.prefix);
  EXPECT_TRUE(pubs.wait_for_readers(1)) << rec.err();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  for (int i = 0; i < kRounds; ++i) {
    pubs.publish(i);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(rec.signal_and_wait(SIGINT, 20'000), 0) << rec.err();
  r.truth = pubs.truth;
  return r;
}

// Typed readers of the played topics; received samples' payload FNV and stamps, in order.
struct Received {
  std::vector<std::uint32_t> cloud_fnv, image_fnv, comp_fnv;
  std::vector<Nanos> cloud_stamp;
  std::vector<Nanos> cloud_arrival;
};

class PlayReaders {
 public:
  PlayReaders(const dds::Participant& p, const std::string& prefix)
      : cloud_t_(p, prefix + "/points", test::KnownPublishers::qos()), cloud_(p, cloud_t_, test::KnownPublishers::qos()),
        image_t_(p, prefix + "/image_raw", test::KnownPublishers::qos()), image_(p, image_t_, test::KnownPublishers::qos()),
        comp_t_(p, prefix + "/image_raw/compressed", test::KnownPublishers::best_effort()),
        comp_(p, comp_t_, test::KnownPublishers::best_effort()) {}
  void poll(Received& r) {
    cloud_.take([&](const msg::PointCloud2& pc, const dds_sample_info_t&) {
      r.cloud_fnv.push_back(test::fnv1a_bytes(pc.data._buffer, pc.data._length));
      r.cloud_stamp.push_back(msg::from_time(pc.header.stamp));
      r.cloud_arrival.push_back(monotonic_now_ns());
    }, 64);
    image_.take([&](const msg::Image& im, const dds_sample_info_t&) {
      r.image_fnv.push_back(test::fnv1a_bytes(im.data._buffer, im.data._length));
    }, 64);
    comp_.take([&](const msg::CompressedImage& ci, const dds_sample_info_t&) {
      r.comp_fnv.push_back(test::fnv1a_bytes(ci.data._buffer, ci.data._length));
    }, 64);
  }

 private:
  dds::Topic<msg::PointCloud2> cloud_t_;
  dds::Reader<msg::PointCloud2> cloud_;
  dds::Topic<msg::Image> image_t_;
  dds::Reader<msg::Image> image_;
  dds::Topic<msg::CompressedImage> comp_t_;
  dds::Reader<msg::CompressedImage> comp_;
};

// Runs `rig play` to its end while polling the readers.
// With `discovery`, the writers it sees alive while the player runs go into `seen` by topic.
int play(const test::TempDir& dir, const std::vector<std::string>& extra, PlayReaders* readers, Received* got,
         nlohmann::json* summary, std::string* err, dds::DiscoveryReader* discovery = nullptr,
         std::map<std::string, dds::Publication>* seen = nullptr) {
  std::vector<std::string> args{"play", "--domain", std::to_string(kPlayDomain), "--dds-profile", profile()};
  if (std::find(extra.begin(), extra.end(), "--delay") == extra.end()) {
    args.emplace_back("--delay");
    args.emplace_back("1.5");
  }
  args.insert(args.end(), extra.begin(), extra.end());
  test::RigChild player(args, (dir.path / "play_out").string(), (dir.path / "play_err").string());
  int rc = -1;
  const Nanos deadline = monotonic_now_ns() + 60'000'000'000;
  for (;;) {
    if (readers != nullptr) readers->poll(*got);
    if (discovery != nullptr)
      for (const auto& pub : discovery->take(256))
        if (pub.alive) (*seen)[pub.topic] = pub;
    rc = player.poll();
    if (rc != -1 || monotonic_now_ns() > deadline) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  if (readers != nullptr) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    readers->poll(*got);
  }
  *summary = player.summary();
  *err = player.err();
  return rc;
}

TEST(Play, ARecordingPlaysByteEqualWithItsQosAndTiming) {
  test::TempDir dir;
  const Recording rec = make_recording(dir);
  dds::Participant p(dds::DomainConfig{kPlayDomain, profile()});
  dds::DiscoveryReader discovery(p);
  PlayReaders readers(p, rec.prefix);
  Received got;
  nlohmann::json summary;
  std::string err;
  std::map<std::string, dds::Publication> pubs;
  ASSERT_EQ(play(dir, {rec.file}, &readers, &got, &summary, &err, &discovery, &pubs), 0) << err;
  ASSERT_FALSE(summary.is_discarded()) << err;
  EXPECT_EQ(summary["played"], kRounds * 6);
  EXPECT_TRUE(summary["problems"].empty());
  ASSERT_EQ(got.cloud_fnv.size(), static_cast<std::size_t>(kRounds));
  ASSERT_EQ(got.image_fnv.size(), static_cast<std::size_t>(kRounds));
  ASSERT_EQ(got.comp_fnv.size(), static_cast<std::size_t>(kRounds));
  for (std::size_t i = 0; i < static_cast<std::size_t>(kRounds); ++i) {
    EXPECT_EQ(got.cloud_fnv[i], rec.truth.at(rec.prefix + "/points")[i].fnv);
    EXPECT_EQ(got.cloud_stamp[i], rec.truth.at(rec.prefix + "/points")[i].stamp_ns);
    EXPECT_EQ(got.image_fnv[i], rec.truth.at(rec.prefix + "/image_raw")[i].fnv);
    EXPECT_EQ(got.comp_fnv[i], rec.truth.at(rec.prefix + "/image_raw/compressed")[i].fnv);
  }
  // The recorded timing: 29 gaps of ~20 ms (+ the publisher's own work) between the first and last cloud.
  const double span_ms = static_cast<double>(got.cloud_arrival.back() - got.cloud_arrival.front()) / 1e6;
  EXPECT_GT(span_ms, 29 * 20.0 * 0.95);
  EXPECT_LT(span_ms, 29 * 20.0 * 1.5 + 100);
  EXPECT_LT(summary["late_ms"]["p50"].get<double>(), 5.0) << summary.dump();
  // The compressed images' writer is best-effort, as recorded; the others reliable.
  ASSERT_TRUE(pubs.count("rt" + rec.prefix + "/image_raw/compressed"));
  EXPECT_EQ(pubs["rt" + rec.prefix + "/image_raw/compressed"].reliability, dds::QosSpec::Reliability::kBestEffort);
  EXPECT_EQ(pubs["rt" + rec.prefix + "/points"].reliability, dds::QosSpec::Reliability::kReliable);
  EXPECT_EQ(pubs["rt" + rec.prefix + "/points"].depth, 64);
}

TEST(Play, AFileMcapCoreWrotePlaysItsKnownTypeAndRefusesTheOther) {
  test::TempDir dir;
  const std::string file = (dir.path / "made.mcap").string();
  const auto [rc, out] = test::run("node " + (test::source_dir() / "tests/js/mcap_make.mjs").string() + " " + file + " 20 2>&1");
  ASSERT_EQ(rc, 0) << out;
  const auto made = nlohmann::json::parse(out);
  dds::Participant p(dds::DomainConfig{kPlayDomain, profile()});
  dds::DiscoveryReader discovery(p);
  dds::Topic<msg::CompressedImage> t(p, "/made/compressed", test::KnownPublishers::best_effort());
  dds::Reader<msg::CompressedImage> reader(p, t, test::KnownPublishers::best_effort());
  std::vector<std::pair<msg::Time, std::uint32_t>> got;
  test::RigChild player({"play", file, "--domain", std::to_string(kPlayDomain), "--dds-profile", profile(), "--delay", "1.5"},
                        (dir.path / "out").string(), (dir.path / "err").string());
  int code = -1;
  const Nanos deadline = monotonic_now_ns() + 60'000'000'000;
  bool best_effort = false;
  while ((code = player.poll()) == -1 && monotonic_now_ns() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    for (const auto& pub : discovery.take(256))
      if (pub.alive && pub.topic == "rt/made/compressed") best_effort = pub.reliability == dds::QosSpec::Reliability::kBestEffort;
    reader.take([&](const msg::CompressedImage& ci, const dds_sample_info_t&) {
      got.emplace_back(ci.header.stamp, test::fnv1a_bytes(ci.data._buffer, ci.data._length));
    });
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  reader.take([&](const msg::CompressedImage& ci, const dds_sample_info_t&) {
    got.emplace_back(ci.header.stamp, test::fnv1a_bytes(ci.data._buffer, ci.data._length));
  });
  EXPECT_EQ(code, 0) << player.err();
  const auto summary = player.summary();
  ASSERT_EQ(got.size(), made["written"].size()) << player.err();
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].first.sec, made["written"][i]["stamp_sec"]);
    EXPECT_EQ(got[i].first.nanosec, made["written"][i]["nanosec"]);
    EXPECT_EQ(got[i].second, made["written"][i]["fnv"]);
  }
  const std::string why = summary["refused"]["/made/unknown"];
  EXPECT_NE(why.find("std_msgs/msg/String is not known to the rig"), std::string::npos) << why;
  EXPECT_NE(player.err().find("/made/unknown: refused"), std::string::npos);
  EXPECT_TRUE(best_effort) << "QoS metadata in names form not applied";
}

TEST(Play, BadFilesNameTheOffsetAndPlayWhatIsIntact) {
  test::TempDir dir;
  const Recording rec = make_recording(dir);
  const auto size = std::filesystem::file_size(rec.file);
  std::vector<char> all(size);
  std::ifstream(rec.file, std::ios::binary).read(all.data(), static_cast<std::streamsize>(size));

  // Cut at 60 %: a killed recorder's file.
  const std::string cut = (dir.path / "cut.mcap").string();
  std::ofstream(cut, std::ios::binary).write(all.data(), static_cast<std::streamsize>(size * 6 / 10));
  std::uint64_t intact = 0;
  {
    record::McapReader r(cut);
    intact = r.for_each_message([](const record::McapMessage&) { return true; });
  }
  ASSERT_GT(intact, 0u);
  nlohmann::json summary;
  std::string err;
  EXPECT_EQ(play(dir, {cut, "--delay", "0", "--rate", "20"}, nullptr, nullptr, &summary, &err), 1);
  EXPECT_NE(err.find("offset"), std::string::npos) << err;
  EXPECT_NE(err.find("truncated"), std::string::npos) << err;
  EXPECT_EQ(summary["played"], intact);

  // One byte flipped in the middle: that chunk's CRC (or its zstd frame) fails; the rest plays.
  const std::string bad = (dir.path / "bad.mcap").string();
  all[size / 2] = static_cast<char>(all[size / 2] ^ 0x5a);
  std::ofstream(bad, std::ios::binary).write(all.data(), static_cast<std::streamsize>(size));
  EXPECT_EQ(play(dir, {bad, "--delay", "0", "--rate", "20"}, nullptr, nullptr, &summary, &err), 1);
  EXPECT_TRUE(err.find("CRC mismatch") != std::string::npos || err.find("does not decompress") != std::string::npos) << err;
  EXPECT_GT(summary["played"].get<int>(), kRounds * 6 / 2);
  EXPECT_LT(summary["played"].get<int>(), kRounds * 6);

  // Not MCAP at all.
  const std::string wrong = dir.write("wrong.mcap", "PK\x03\x04 this is a zip file, not a recording");
  EXPECT_EQ(play(dir, {wrong}, nullptr, nullptr, &summary, &err), 1);
  EXPECT_NE(err.find("wrong magic at offset 0"), std::string::npos) << err;
}

}  // namespace
}  // namespace sensor_rig::rig
