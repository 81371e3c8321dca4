// RawReader / RawWriter against the typed wrapper in another participant: the bytes a raw reader
// hands out are the CDR the typed writer sent (parsed back field by field), with its source
// timestamp; the same bytes written by a raw writer arrive at a typed reader as the original sample.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include <cstring>
#include <string>
#include <vector>

#include "sensor_rig/dds/raw_topic.hpp"
#include "sensor_rig/dds/roudi.hpp"
#include "sensor_rig/dds/types.hpp"
#include "wait_bounds.hpp"

namespace sensor_rig::dds {
namespace {

constexpr dds_domainid_t kDomain = 47;

std::string unique_topic(const char* what) { return "/test/raw/" + std::to_string(::getpid()) + "/" + what; }

std::vector<std::uint8_t> payload(int i) {
  std::vector<std::uint8_t> d(1000 + static_cast<std::size_t>(i) * 7);
  for (std::size_t k = 0; k < d.size(); ++k) d[k] = static_cast<std::uint8_t>(k * 31 + static_cast<std::size_t>(i));
  return d;
}

TEST(RawTopic, ReadsTheCdrATypedWriterSentAndWritesItBack) {
  Participant theirs(DomainConfig{kDomain, {}});
  Participant mine(DomainConfig{kDomain, {}});
  const std::string in_name = unique_topic("in"), out_name = unique_topic("out");
  QosSpec qos;
  qos.depth = 64;
  Topic<msg::PointCloud2> in_topic(theirs, in_name, qos);
  Writer<msg::PointCloud2> typed_writer(theirs, in_topic, qos);
  Topic<msg::PointCloud2> out_topic(theirs, out_name, qos);
  Reader<msg::PointCloud2> typed_reader(theirs, out_topic, qos);

  const RegisteredType* type = find_type("sensor_msgs::msg::dds_::PointCloud2_");
  ASSERT_NE(type, nullptr);
  RawReader raw_reader(mine, ros_to_dds_topic(in_name), *type, qos);
  RawWriter raw_writer(mine, ros_to_dds_topic(out_name), *type, qos);
  ASSERT_TRUE(typed_writer.wait_for_readers(1, test::kDiscoveryMs));
  ASSERT_TRUE(typed_reader.wait_for_writers(1, test::kDiscoveryMs));
  ASSERT_TRUE(wait_until([&] { return raw_writer.matched() >= 1; }, test::kDiscoveryMs));

  constexpr int kN = 20;
  char frame[] = "lidar_front";
  for (int i = 0; i < kN; ++i) {
    auto data = payload(i);
    msg::PointCloud2 pc{};
    pc.header.stamp = msg::to_time(1'700'000'000'000'000'000 + i);
    pc.header.frame_id = frame;
    pc.height = 1;
    pc.width = static_cast<std::uint32_t>(i);
    pc.point_step = 7;
    pc.data._buffer = data.data();
    pc.data._length = pc.data._maximum = static_cast<std::uint32_t>(data.size());
    ASSERT_TRUE(typed_writer.write(pc, 1'700'000'000'000'000'000 + 1000 * i).ok());
  }
  std::vector<std::vector<std::byte>> got;
  std::vector<Nanos> source_ts;
  RawSample s;
  const Nanos deadline = monotonic_now_ns() + 10'000'000'000;
  while (static_cast<int>(got.size()) < kN && monotonic_now_ns() < deadline) {
    while (raw_reader.take(s)) {
      got.push_back(s.copy());
      source_ts.push_back(s.source_ts());
      EXPECT_GT(s.receive_ts(), 0);
    }
    dds_sleepfor(DDS_MSECS(5));
  }
  ASSERT_EQ(static_cast<int>(got.size()), kN);
  EXPECT_EQ(raw_reader.malformed(), 0u);
  for (int i = 0; i < kN; ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(source_ts[static_cast<std::size_t>(i)], 1'700'000'000'000'000'000 + 1000 * i);
    const auto body = cdr_body(got[static_cast<std::size_t>(i)]);
    ASSERT_TRUE(body);
    PointCloud2View v;
    ASSERT_EQ(parse_cdr(*body, v), CdrStatus::kOk);
    EXPECT_EQ(v.width, static_cast<std::uint32_t>(i));
    EXPECT_EQ(v.header.frame_id, "lidar_front");
    const auto want = payload(i);
    ASSERT_EQ(v.data.size(), want.size());
    EXPECT_EQ(std::memcmp(v.data.data(), want.data(), want.size()), 0);
    ASSERT_TRUE(raw_writer.write(got[static_cast<std::size_t>(i)], 42'000 + i).ok());
  }
  int back = 0;
  const Nanos deadline2 = monotonic_now_ns() + 10'000'000'000;
  while (back < kN && monotonic_now_ns() < deadline2) {
    typed_reader.wait(50);
    typed_reader.take([&](const msg::PointCloud2& pc, const dds_sample_info_t& info) {
      EXPECT_EQ(info.source_timestamp, 42'000 + back);
      EXPECT_EQ(pc.width, static_cast<std::uint32_t>(back));
      const auto want = payload(back);
      ASSERT_EQ(pc.data._length, want.size());
      EXPECT_EQ(std::memcmp(pc.data._buffer, want.data(), want.size()), 0);
      ++back;
    });
  }
  EXPECT_EQ(back, kN);
}

TEST(RawTopic, WriterRefusesBytesShorterThanAHeader) {
  Participant mine(DomainConfig{kDomain, {}});
  const RegisteredType* type = find_type("sensor_rig_msgs::msg::dds_::SourceStamps_");
  ASSERT_NE(type, nullptr);
  RawWriter w(mine, ros_to_dds_topic(unique_topic("short")), *type, QosSpec{});
  const std::byte two[2] = {};
  EXPECT_FALSE(w.write(std::span<const std::byte>(two), 1).ok());
}

// Over shared memory: the raw reader's samples are the iceoryx chunks themselves (two pieces: a
// made header, then the chunk), byte-equal to what the typed writer sent; a raw writer's samples
// reach a typed reader. Run in a child (RouDi SIGTERMs registered processes when it stops).
std::string shm_round_trip() {
  DomainConfig cfg;
  cfg.domain_id = 95;
  cfg.transport = Transport::kShm;
  Participant a(cfg);
  Participant b(cfg);
  QosSpec q;
  q.depth = 16;
  Topic<msg::PointCloud2> in_topic(a, "/test/raw/shm/in", q);
  Writer<msg::PointCloud2> typed_writer(a, in_topic, q);
  Topic<msg::PointCloud2> out_topic(a, "/test/raw/shm/out", q);
  Reader<msg::PointCloud2> typed_reader(a, out_topic, q);
  const RegisteredType* type = find_type("sensor_msgs::msg::dds_::PointCloud2_");
  RawReader raw_reader(b, "rt/test/raw/shm/in", *type, q);
  RawWriter raw_writer(b, "rt/test/raw/shm/out", *type, q);
  if (!typed_writer.wait_for_readers(1, test::kDiscoveryMs) || !typed_reader.wait_for_writers(1, test::kDiscoveryMs))
    return "not matched";
  constexpr int kN = 10;
  char frame[] = "shm";
  for (int i = 0; i < kN; ++i) {
    auto data = payload(i);
    msg::PointCloud2 pc{};
    pc.header.frame_id = frame;
    pc.width = static_cast<std::uint32_t>(i);
    pc.data = {static_cast<std::uint32_t>(data.size()), static_cast<std::uint32_t>(data.size()), data.data(), false};
    if (!typed_writer.write(pc, 1000 + i).ok()) return "typed write failed";
  }
  std::string problems;
  int got = 0, in_chunk = 0;
  RawSample s;
  wait_until([&] {
    while (raw_reader.take(s)) {
      in_chunk += s.in_shared_memory() ? 1 : 0;
      if (s.in_shared_memory() && (s.first().size() != 4 || s.first()[1] != std::byte{1})) problems += "header; ";
      const auto bytes = s.copy();
      const auto body = cdr_body(bytes);
      PointCloud2View v;
      const auto want = payload(got);
      if (!body || parse_cdr(*body, v) != CdrStatus::kOk || v.width != static_cast<std::uint32_t>(got) ||
          v.data.size() != want.size() || std::memcmp(v.data.data(), want.data(), want.size()) != 0)
        problems += "sample " + std::to_string(got) + " differs; ";
      const std::span<const std::byte> pieces[] = {s.first(), s.second()};
      if (!raw_writer.write(pieces, 2000 + got).ok()) problems += "raw write failed; ";
      ++got;
    }
    return got >= kN;
  }, 5000);
  if (got != kN) problems += "raw reader got " + std::to_string(got) + "; ";
  if (in_chunk == 0) problems += "no sample came in an iceoryx chunk; ";
  int back = 0;
  wait_until([&] {
    typed_reader.take([&](const msg::PointCloud2& pc, const dds_sample_info_t&) {
      const auto want = payload(back);
      if (pc.data._length != want.size() || std::memcmp(pc.data._buffer, want.data(), want.size()) != 0)
        problems += "written back " + std::to_string(back) + " differs; ";
      ++back;
    });
    return back >= kN;
  }, 5000);
  if (back != kN) problems += "typed reader got " + std::to_string(back) + " back; ";
  return problems;
}

TEST(RawTopic, SharedMemoryChunksReadInPlaceAndWrittenBack) {
  if (::access("/usr/bin/iox-roudi", X_OK) != 0) GTEST_SKIP() << "no iox-roudi (Debian package iceoryx)";
  if (probe_roudi().pid != 0) GTEST_SKIP() << "another RouDi runs on this machine; this test needs its own";
  char dir[] = "/tmp/rig-raw-XXXXXX";
  ASSERT_NE(::mkdtemp(dir), nullptr);
  {
    RouDi roudi("", std::string(dir) + "/roudi.log", false);
    EXPECT_EXIT(
        {
          const std::string problems = shm_round_trip();
          std::fprintf(stderr, "%s\n", problems.empty() ? "round trip ok" : problems.c_str());
          std::_Exit(problems.empty() ? 0 : 1);
        },
        ::testing::ExitedWithCode(0), "round trip ok");
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace sensor_rig::dds
