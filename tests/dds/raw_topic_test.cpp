// RawReader / RawWriter against the typed wrapper in another participant: the bytes a raw reader
// hands out are the CDR the typed writer sent (parsed back field by field), with its source
// timestamp; the same bytes written by a raw writer arrive at a typed reader as the original sample.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <string>
#include <vector>

#include "sensor_rig/dds/raw_topic.hpp"
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

}  // namespace
}  // namespace sensor_rig::dds
