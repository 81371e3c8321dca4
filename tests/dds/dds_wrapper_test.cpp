// The DDS wrapper: type names as rmw_cyclonedds registers them, and a round trip through Cyclone.
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "sensor_rig/dds/publish_stats.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/dds/view_reader.hpp"
#include "wait_bounds.hpp"

namespace sensor_rig::dds {
namespace {

TEST(DdsNames, RosTopicMapping) {
  EXPECT_EQ(ros_to_dds_topic("/sensors/lidar/front/points"), "rt/sensors/lidar/front/points");
  EXPECT_EQ(dds_to_ros_topic("rt/sensors/lidar/front/points"), "/sensors/lidar/front/points");
}

TEST(DdsNames, TypeNamesMatchRmwCycloneDds) {
  EXPECT_STREQ(TypeSupport<msg::PointCloud2>::descriptor()->m_typename, "sensor_msgs::msg::dds_::PointCloud2_");
  EXPECT_STREQ(TypeSupport<msg::DiagnosticArray>::descriptor()->m_typename,
               "diagnostic_msgs::msg::dds_::DiagnosticArray_");
  EXPECT_STREQ(TypeSupport<msg::Image>::descriptor()->m_typename, "sensor_msgs::msg::dds_::Image_");
  EXPECT_EQ(TypeSupport<msg::PointCloud2>::descriptor()->m_nkeys, 0u);
}

// The nodes' publish bookkeeping: failures counted, the rate follows a change within a few
// samples, a clock step back neither counts as a rate nor poisons it.
TEST(PublishStats, CountsFailuresAndFollowsTheRate) {
  PublishStats st;
  const Result ok(0), bad(DDS_RETCODE_TIMEOUT);
  Nanos t = 1'000'000'000;
  EXPECT_TRUE(st.count(ok, t));
  EXPECT_EQ(st.rate_hz(), 0.0);  // one sample: no interval yet
  for (int i = 0; i < 20; ++i) EXPECT_TRUE(st.count(ok, t += 100'000'000));
  EXPECT_NEAR(st.rate_hz(), 10.0, 1e-9);
  EXPECT_FALSE(st.count(bad, t += 100'000'000));
  EXPECT_EQ(st.write_errors(), 1u);
  EXPECT_EQ(st.samples(), 22u);
  const double before = st.rate_hz();
  EXPECT_TRUE(st.count(ok, t -= 5'000'000'000));  // the clock stepped back 5 s
  EXPECT_EQ(st.rate_hz(), before);
  for (int i = 0; i < 25; ++i) st.count(ok, t += 200'000'000);  // then 5 Hz in the new timeline
  EXPECT_NEAR(st.rate_hz(), 5.0, 0.05);
  EXPECT_FALSE(st.count_write(bad));
  EXPECT_EQ(st.write_errors(), 2u);
  EXPECT_EQ(st.samples(), 48u);
  EXPECT_EQ(st.last_ns(), t);
}

TEST(DdsTime, RoundTrip) {
  for (Nanos ns : {Nanos{0}, Nanos{1'700'000'000'123'456'789}, Nanos{-1}, Nanos{999'999'999}}) {
    EXPECT_EQ(msg::from_time(msg::to_time(ns)), ns);
    EXPECT_LT(msg::to_time(ns).nanosec, 1'000'000'000u);
  }
}

TEST(DdsRoundTrip, PointCloudInProcessKeepsBytesAndSourceTimestamp) {
  Participant p;
  Topic<msg::PointCloud2> topic(p, "/test/wrapper/points");
  Reader<msg::PointCloud2> reader(p, topic);
  Writer<msg::PointCloud2> writer(p, topic);
  ASSERT_TRUE(writer.wait_for_readers(1, test::kDiscoveryMs));

  std::vector<std::uint8_t> bytes(100000);
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(i * 7);
  msg::PointCloud2 pc{};
  pc.header.stamp = msg::to_time(1'700'000'000'000'000'123);
  pc.header.frame_id = const_cast<char*>("lidar");
  pc.width = 1000;
  pc.height = 1;
  pc.point_step = 100;
  pc.row_step = 100000;
  pc.data._buffer = bytes.data();
  pc.data._length = pc.data._maximum = static_cast<uint32_t>(bytes.size());
  pc.data._release = false;
  const Nanos ts = vehicle_now_ns();
  ASSERT_TRUE(writer.write(pc, ts).ok());

  ASSERT_TRUE(reader.wait(5000));
  int got = 0;
  reader.take([&](const msg::PointCloud2& s, const dds_sample_info_t& info) {
    ++got;
    EXPECT_EQ(info.source_timestamp, ts);
    EXPECT_EQ(msg::from_time(s.header.stamp), 1'700'000'000'000'000'123);
    EXPECT_STREQ(s.header.frame_id, "lidar");
    ASSERT_EQ(s.data._length, bytes.size());
    EXPECT_EQ(std::memcmp(s.data._buffer, bytes.data(), bytes.size()), 0);
  });
  EXPECT_EQ(got, 1);
}

// The view reader: two clouds (one with 100 kB, fragmented) read in place from the received
// serdata; the first view stays valid while the second is taken (each holds its own sample).
TEST(DdsRoundTrip, PointCloudViewsReadTheSerializedSampleInPlace) {
  Participant p;
  QosSpec q;
  q.depth = 4;
  Topic<msg::PointCloud2> topic(p, "/test/wrapper/view_points", q);
  Reader<msg::PointCloud2> reader(p, topic, q);
  Writer<msg::PointCloud2> writer(p, topic, q);
  ASSERT_TRUE(writer.wait_for_readers(1, test::kDiscoveryMs));

  std::vector<std::uint8_t> bytes(100000);
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(i * 13);
  const std::vector<msg::PointField> fields = {{const_cast<char*>("x"), 0, 7, 1}, {const_cast<char*>("ring"), 16, 4, 1}};
  msg::PointCloud2 pc{};
  pc.header.frame_id = const_cast<char*>("lidar_front");
  pc.width = 1000;
  pc.height = 1;
  pc.fields._buffer = const_cast<msg::PointField*>(fields.data());
  pc.fields._length = pc.fields._maximum = 2;
  pc.point_step = 100;
  pc.row_step = 100000;
  pc.is_dense = true;
  pc.data._buffer = bytes.data();
  pc.data._length = pc.data._maximum = static_cast<uint32_t>(bytes.size());
  for (int i = 0; i < 2; ++i) {
    pc.header.stamp = msg::to_time(1'000 + i);
    ASSERT_TRUE(writer.write(pc, vehicle_now_ns()).ok());
  }

  ViewCounts counts;
  SerializedSample first_sample, second_sample;
  PointCloud2View first, second;
  ASSERT_TRUE(wait_until([&] { return take_view(reader.handle(), first_sample, first, counts); }, 30'000));
  ASSERT_TRUE(wait_until([&] { return take_view(reader.handle(), second_sample, second, counts); }, 30'000));
  EXPECT_EQ(first.header.nanosec, 1'000u);
  EXPECT_EQ(second.header.nanosec, 1'001u);
  for (const PointCloud2View* v : {&first, &second}) {
    EXPECT_EQ(v->header.frame_id, "lidar_front");
    ASSERT_EQ(v->fields.size(), 2u);
    EXPECT_EQ(v->fields[1].name, "ring");
    EXPECT_EQ(v->fields[1].offset, 16u);
    EXPECT_EQ(v->width, 1000u);
    EXPECT_TRUE(v->is_dense);
    ASSERT_EQ(v->data.size(), bytes.size());
    EXPECT_EQ(std::memcmp(v->data.data(), bytes.data(), bytes.size()), 0);
  }
  EXPECT_FALSE(first_sample.in_shared_memory());  // no RouDi here: the network path
  EXPECT_EQ(counts.in_serdata, 2u);
  EXPECT_EQ(counts.malformed, 0u);
  EXPECT_FALSE(take_view(reader.handle(), second_sample, second, counts));  // none left: the sample is released
  EXPECT_FALSE(second_sample.body().has_value());
}

}  // namespace
}  // namespace sensor_rig::dds
