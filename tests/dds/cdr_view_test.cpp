// dds/cdr_view: the PointCloud2 / Image views against Cyclone's own serializer (idlc's ops, both
// byte orders, random samples), and against truncated, corrupted and hand-made malformed buffers.
#include "sensor_rig/dds/cdr_view.hpp"

#include <dds/ddsi/ddsi_cdrstream.h>
#include <dds/ddsi/q_protocol.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "sensor_msgs.h"
#include "sensor_rig_msgs.h"

namespace sensor_rig::dds {
namespace {

using Cloud = sensor_msgs_msg_dds__PointCloud2_;
using Image = sensor_msgs_msg_dds__Image_;
using Bytes = std::vector<std::byte>;

// The sample as Cyclone writes it (serdata layout): encapsulation header, then the members.
template <class T>
Bytes serialize(const T& sample, const dds_topic_descriptor_t& desc, std::endian order) {
  Bytes out(4, std::byte{0});
  out[1] = order == std::endian::little ? std::byte{1} : std::byte{0};
  const char* data = reinterpret_cast<const char*>(&sample);
  dds_ostream_t os{};
  if (order == std::endian::little) {
    dds_ostreamLE_t le{};
    dds_ostreamLE_init(&le, 0, CDR_ENC_VERSION_1);
    dds_stream_writeLE(&le, data, desc.m_ops);
    os = le.x;
  } else {
    dds_ostreamBE_t be{};
    dds_ostreamBE_init(&be, 0, CDR_ENC_VERSION_1);
    dds_stream_writeBE(&be, data, desc.m_ops);
    os = be.x;
  }
  const auto* p = reinterpret_cast<const std::byte*>(os.m_buffer);
  out.insert(out.end(), p, p + os.m_index);
  dds_ostream_fini(&os);
  return out;
}

// A random cloud whose strings and sequences point into `store` (kept alive by the caller).
struct RandomCloud {
  Cloud msg{};
  std::string frame_id;
  std::vector<std::string> names;
  std::vector<sensor_msgs_msg_dds__PointField_> fields;
  std::vector<std::uint8_t> data;

  explicit RandomCloud(std::mt19937& rng) {
    auto pick = [&](std::uint32_t lo, std::uint32_t hi) { return std::uniform_int_distribution<std::uint32_t>(lo, hi)(rng); };
    frame_id.assign(pick(0, 40), 'f');
    for (auto& c : frame_id) c = static_cast<char>('a' + pick(0, 25));
    names.resize(pick(0, 9));
    for (auto& n : names) n.assign(pick(0, 11), 'x');
    for (const auto& n : names) {
      sensor_msgs_msg_dds__PointField_ f{};
      f.name = const_cast<char*>(n.c_str());
      f.offset = pick(0, 64);
      f.datatype = static_cast<std::uint8_t>(pick(1, 8));
      f.count = pick(0, 3);
      fields.push_back(f);
    }
    data.resize(pick(0, 5000));
    for (auto& b : data) b = static_cast<std::uint8_t>(pick(0, 255));
    msg.header.stamp.sec = static_cast<std::int32_t>(pick(0, 0xffffffffu));
    msg.header.stamp.nanosec = pick(0, 999'999'999);
    msg.header.frame_id = frame_id.data();
    msg.height = pick(0, 64);
    msg.width = pick(0, 100000);
    msg.fields._buffer = fields.data();
    msg.fields._length = msg.fields._maximum = static_cast<std::uint32_t>(fields.size());
    msg.is_bigendian = pick(0, 1) == 1;
    msg.point_step = pick(0, 64);
    msg.row_step = pick(0, 1u << 20);
    msg.data._buffer = data.data();
    msg.data._length = msg.data._maximum = static_cast<std::uint32_t>(data.size());
    msg.is_dense = pick(0, 1) == 1;
  }
};

bool same_bytes(std::span<const std::byte> a, const std::vector<std::uint8_t>& b) {
  return a.size() == b.size() && (b.empty() || std::memcmp(a.data(), b.data(), b.size()) == 0);
}

bool inside(std::span<const std::byte> part, std::span<const std::byte> whole) {
  return part.empty() || (part.data() >= whole.data() && part.data() + part.size() <= whole.data() + whole.size());
}
bool inside(std::string_view part, std::span<const std::byte> whole) {
  return inside(std::as_bytes(std::span(part.data(), part.size())), whole);
}

void expect_view_inside(const PointCloud2View& v, std::span<const std::byte> buf) {
  EXPECT_TRUE(inside(v.header.frame_id, buf));
  EXPECT_TRUE(inside(v.data, buf));
  for (const auto& f : v.fields) EXPECT_TRUE(inside(f.name, buf));
}

TEST(CdrView, RandomCloudsRoundTripInBothByteOrders) {
  std::mt19937 rng(13);
  PointCloud2View v;  // reused, as a reader does
  for (int i = 0; i < 200; ++i) {
    const RandomCloud c(rng);
    const auto order = i % 2 == 0 ? std::endian::little : std::endian::big;
    const Bytes wire = serialize(c.msg, sensor_msgs_msg_dds__PointCloud2__desc, order);
    const auto body = cdr_body(wire);
    ASSERT_TRUE(body.has_value());
    EXPECT_EQ(body->order, order);
    ASSERT_EQ(parse_cdr(*body, v), CdrStatus::kOk) << "cloud " << i;
    EXPECT_EQ(v.header.sec, c.msg.header.stamp.sec);
    EXPECT_EQ(v.header.nanosec, c.msg.header.stamp.nanosec);
    EXPECT_EQ(v.header.frame_id, c.frame_id);
    EXPECT_EQ(v.height, c.msg.height);
    EXPECT_EQ(v.width, c.msg.width);
    ASSERT_EQ(v.fields.size(), c.fields.size());
    for (std::size_t k = 0; k < c.fields.size(); ++k) {
      EXPECT_EQ(v.fields[k].name, c.names[k]);
      EXPECT_EQ(v.fields[k].offset, c.fields[k].offset);
      EXPECT_EQ(v.fields[k].datatype, c.fields[k].datatype);
      EXPECT_EQ(v.fields[k].count, c.fields[k].count);
    }
    EXPECT_EQ(v.is_bigendian, c.msg.is_bigendian);
    EXPECT_EQ(v.point_step, c.msg.point_step);
    EXPECT_EQ(v.row_step, c.msg.row_step);
    EXPECT_TRUE(same_bytes(v.data, c.data));
    EXPECT_EQ(v.is_dense, c.msg.is_dense);
    expect_view_inside(v, wire);
  }
}

TEST(CdrView, ImageRoundTripsAndItsDataIsInPlace) {
  std::vector<std::uint8_t> pixels(640 * 3 + 7);
  for (std::size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<std::uint8_t>(i * 7);
  std::string frame = "camera_front_narrow", encoding = "bgr8";
  Image m{};
  m.header.stamp.sec = -3;
  m.header.stamp.nanosec = 17;
  m.header.frame_id = frame.data();
  m.height = 1;
  m.width = 640;
  m.encoding = encoding.data();
  m.is_bigendian = 1;
  m.step = 1920;
  m.data._buffer = pixels.data();
  m.data._length = m.data._maximum = static_cast<std::uint32_t>(pixels.size());
  for (const auto order : {std::endian::little, std::endian::big}) {
    const Bytes wire = serialize(m, sensor_msgs_msg_dds__Image__desc, order);
    ImageView v;
    ASSERT_EQ(parse_cdr(*cdr_body(wire), v), CdrStatus::kOk);
    EXPECT_EQ(v.header.sec, -3);
    EXPECT_EQ(v.header.nanosec, 17u);
    EXPECT_EQ(v.header.frame_id, frame);
    EXPECT_EQ(v.encoding, encoding);
    EXPECT_EQ(v.width, 640u);
    EXPECT_EQ(v.height, 1u);
    EXPECT_EQ(v.is_bigendian, 1);
    EXPECT_EQ(v.step, 1920u);
    EXPECT_TRUE(same_bytes(v.data, pixels));
    EXPECT_TRUE(inside(v.data, wire));
  }
}

// A shared-memory chunk holds the members without the encapsulation header, in native order.
TEST(CdrView, ParsesABodyWithoutEncapsulation) {
  std::mt19937 rng(7);
  const RandomCloud c(rng);
  const Bytes wire = serialize(c.msg, sensor_msgs_msg_dds__PointCloud2__desc, std::endian::native);
  const Bytes chunk(wire.begin() + 4, wire.end());
  PointCloud2View v;
  ASSERT_EQ(parse_cdr(CdrBody{chunk, std::endian::native}, v), CdrStatus::kOk);
  EXPECT_EQ(v.header.frame_id, c.frame_id);
  EXPECT_TRUE(same_bytes(v.data, c.data));
}

TEST(CdrView, EveryTruncationIsReportedAsTruncated) {
  std::mt19937 rng(3);
  RandomCloud c(rng);
  c.data.resize(100);
  c.msg.data._length = c.msg.data._maximum = 100;
  for (const auto order : {std::endian::little, std::endian::big}) {
    const Bytes wire = serialize(c.msg, sensor_msgs_msg_dds__PointCloud2__desc, order);
    const auto body = cdr_body(wire);
    ASSERT_TRUE(body.has_value());
    PointCloud2View v;
    for (std::size_t n = 0; n < body->body.size(); ++n) {
      // A fresh copy of just the prefix: ASan sees any read past it.
      const Bytes prefix(body->body.begin(), body->body.begin() + static_cast<std::ptrdiff_t>(n));
      EXPECT_EQ(parse_cdr(CdrBody{prefix, order}, v), CdrStatus::kTruncated) << "prefix " << n;
    }
  }
}

TEST(CdrView, CorruptedBytesNeverReadOutside) {
  std::mt19937 rng(11);
  const RandomCloud c(rng);
  const Bytes wire = serialize(c.msg, sensor_msgs_msg_dds__PointCloud2__desc, std::endian::little);
  int refused = 0;
  PointCloud2View v;
  ImageView iv;
  // Every byte of the first 160 (header, fields, lengths) set to a few telling values.
  for (std::size_t at = 4; at < std::min<std::size_t>(wire.size(), 160); ++at) {
    for (const unsigned value : {0x00u, 0x02u, 0x7fu, 0xffu}) {
      Bytes bad = wire;
      bad[at] = std::byte{static_cast<unsigned char>(value)};
      const auto body = cdr_body(bad);
      ASSERT_TRUE(body.has_value());
      if (parse_cdr(*body, v) == CdrStatus::kOk) {
        expect_view_inside(v, bad);
      } else {
        ++refused;
      }
      if (parse_cdr(*body, iv) == CdrStatus::kOk) {
        EXPECT_TRUE(inside(iv.data, bad));
      }
    }
  }
  EXPECT_GT(refused, 0);
}

// Hand-made little-endian bodies, one defect each.
Bytes le_u32(std::initializer_list<std::uint32_t> words) {
  Bytes b;
  for (std::uint32_t w : words) {
    for (int i = 0; i < 4; ++i) b.push_back(std::byte{static_cast<unsigned char>(w >> (8 * i))});
  }
  return b;
}

TEST(CdrView, MalformedFieldsHaveTheirOwnStatus) {
  PointCloud2View v;
  ImageView iv;
  // sec, nanosec, frame_id length 2 "a\0", height, width, then a field count far beyond the buffer.
  Bytes b = le_u32({1, 2, 2});
  b.push_back(std::byte{'a'});
  b.push_back(std::byte{0});
  b.resize(12 + 4, std::byte{0});  // pad to 4
  const Bytes tail = le_u32({1, 2, 0x10000000});
  b.insert(b.end(), tail.begin(), tail.end());
  EXPECT_EQ(parse_cdr(CdrBody{b, std::endian::little}, v), CdrStatus::kTruncated);

  const Bytes no_nul = [] {
    Bytes x = le_u32({1, 2, 2});
    x.push_back(std::byte{'a'});
    x.push_back(std::byte{'b'});
    return x;
  }();
  EXPECT_EQ(parse_cdr(CdrBody{no_nul, std::endian::little}, v), CdrStatus::kBadString);
  const Bytes empty_string = le_u32({1, 2, 0});
  EXPECT_EQ(parse_cdr(CdrBody{empty_string, std::endian::little}, iv), CdrStatus::kBadString);

  // A valid empty cloud except is_bigendian = 2.
  Bytes bad_bool = le_u32({1, 2, 1, 0, 0, 0, 0});  // frame_id "" (length 1, the NUL + 3 pad), h, w, 0 fields
  bad_bool.push_back(std::byte{2});
  bad_bool.resize(32, std::byte{0});
  const Bytes rest = le_u32({0, 0, 0});  // point_step, row_step, data length 0
  bad_bool.insert(bad_bool.end(), rest.begin(), rest.end());
  bad_bool.push_back(std::byte{1});
  EXPECT_EQ(parse_cdr(CdrBody{bad_bool, std::endian::little}, v), CdrStatus::kBadBoolean);
  bad_bool[28] = std::byte{1};
  EXPECT_EQ(parse_cdr(CdrBody{bad_bool, std::endian::little}, v), CdrStatus::kOk);
  EXPECT_TRUE(v.is_bigendian);
  EXPECT_TRUE(v.is_dense);
  EXPECT_TRUE(v.data.empty());
}

TEST(CdrView, OnlyPlainCdrEncapsulationsAreAccepted) {
  EXPECT_FALSE(cdr_body(Bytes{}).has_value());
  EXPECT_FALSE(cdr_body(Bytes(3, std::byte{0})).has_value());
  EXPECT_EQ(cdr_body(Bytes{std::byte{0}, std::byte{0}, std::byte{0}, std::byte{0}})->order, std::endian::big);
  EXPECT_EQ(cdr_body(Bytes{std::byte{0}, std::byte{1}, std::byte{0}, std::byte{0}})->order, std::endian::little);
  for (const unsigned id : {0x0002u, 0x0003u, 0x0010u, 0x0011u, 0x0100u}) {  // PL_CDR, XCDR2, garbage
    const Bytes b{std::byte{static_cast<unsigned char>(id >> 8)}, std::byte{static_cast<unsigned char>(id)},
                  std::byte{0}, std::byte{0}};
    EXPECT_FALSE(cdr_body(b).has_value()) << id;
  }
}

// `RIG_CDR_SEED_DIR=tests/fuzz/corpus/cdr_view cdr_view_test --gtest_filter=*Seeds*` writes the
// fuzz harness's committed seeds (its input: one selector byte, then the serialized sample).
TEST(CdrView, WritesFuzzSeedsWhenAsked) {
  const char* dir = std::getenv("RIG_CDR_SEED_DIR");
  if (dir == nullptr) GTEST_SKIP() << "RIG_CDR_SEED_DIR not set";
  std::mt19937 rng(5);
  for (int i = 0; i < 4; ++i) {
    RandomCloud c(rng);
    c.data.resize(c.data.size() % 64);
    c.msg.data._length = c.msg.data._maximum = static_cast<std::uint32_t>(c.data.size());
    const Bytes wire = serialize(c.msg, sensor_msgs_msg_dds__PointCloud2__desc, i == 1 ? std::endian::big : std::endian::native);
    std::ofstream f(std::filesystem::path(dir) / ("cloud_" + std::to_string(i)), std::ios::binary);
    f.put(static_cast<char>(i == 3 ? 2 : 0));  // the last one as a chunk body (no encapsulation)
    const std::size_t skip = i == 3 ? 4 : 0;
    f.write(reinterpret_cast<const char*>(wire.data() + skip), static_cast<std::streamsize>(wire.size() - skip));
    ASSERT_TRUE(f.good());
  }
}

// The raw channels (issue 29): Cyclone's serializer writes, the views read back every field; every
// truncation is kTruncated (or a string error), never a read past the end.
TEST(CdrView, LidarPacketsAndCanFrameRoundTripInBothByteOrders) {
  std::vector<std::uint8_t> a(1206), b(512);
  for (std::size_t i = 0; i < a.size(); ++i) a[i] = static_cast<std::uint8_t>(i * 7);
  for (std::size_t i = 0; i < b.size(); ++i) b[i] = static_cast<std::uint8_t>(i * 3 + 1);
  sensor_rig_msgs_msg_dds__LidarPacket_ packets[2] = {};
  packets[0].stamp = {1'700'000'000, 123'456'789};
  packets[0].src_address = 0xC0A801C9;
  packets[0].src_port = 2368;
  packets[0].dst_port = 2368;
  packets[0].data = {static_cast<std::uint32_t>(a.size()), static_cast<std::uint32_t>(a.size()), a.data(), false};
  packets[1].stamp = {1'700'000'001, 5};
  packets[1].src_address = 0x7F000001;
  packets[1].src_port = 40000;
  packets[1].dst_port = 8308;
  packets[1].data = {static_cast<std::uint32_t>(b.size()), static_cast<std::uint32_t>(b.size()), b.data(), false};
  char frame[] = "front", model[] = "VLP-32C";
  sensor_rig_msgs_msg_dds__LidarPackets_ m{};
  m.header.stamp = packets[0].stamp;
  m.header.frame_id = frame;
  m.model = model;
  m.data_port = 2368;
  m.packets = {2, 2, packets, false};
  std::uint8_t can_data[3] = {0x16, 0x10, 0xff};
  char bus[] = "can0";
  sensor_rig_msgs_msg_dds__CanFrame_ f{};
  f.header.stamp = {1'700'000'002, 7};
  f.header.frame_id = bus;
  f.id = 0x18FF1234;
  f.is_extended = true;
  f.is_fd = true;
  f.esi = true;
  f.data = {3, 3, can_data, false};
  for (const auto order : {std::endian::little, std::endian::big}) {
    const Bytes raw = serialize(m, sensor_rig_msgs_msg_dds__LidarPackets__desc, order);
    LidarPacketsView v;
    ASSERT_EQ(parse_cdr(*cdr_body(raw), v), CdrStatus::kOk);
    EXPECT_EQ(v.header.frame_id, "front");
    EXPECT_EQ(v.model, "VLP-32C");
    EXPECT_EQ(v.data_port, 2368);
    ASSERT_EQ(v.packets.size(), 2u);
    EXPECT_EQ(v.packets[0].sec, 1'700'000'000);
    EXPECT_EQ(v.packets[0].nanosec, 123'456'789u);
    EXPECT_EQ(v.packets[0].src_address, 0xC0A801C9u);
    EXPECT_EQ(v.packets[1].src_port, 40000);
    EXPECT_EQ(v.packets[1].dst_port, 8308);
    ASSERT_EQ(v.packets[0].data.size(), a.size());
    EXPECT_EQ(std::memcmp(v.packets[0].data.data(), a.data(), a.size()), 0);
    ASSERT_EQ(v.packets[1].data.size(), b.size());
    EXPECT_EQ(std::memcmp(v.packets[1].data.data(), b.data(), b.size()), 0);
    for (std::size_t cut = 4; cut < raw.size(); cut += 37) {
      const Bytes part(raw.begin(), raw.begin() + static_cast<std::ptrdiff_t>(cut));
      EXPECT_NE(parse_cdr(*cdr_body(part), v), CdrStatus::kOk) << cut;
    }
    const Bytes can = serialize(f, sensor_rig_msgs_msg_dds__CanFrame__desc, order);
    CanFrameView c;
    ASSERT_EQ(parse_cdr(*cdr_body(can), c), CdrStatus::kOk);
    EXPECT_EQ(c.header.frame_id, "can0");
    EXPECT_EQ(c.id, 0x18FF1234u);
    EXPECT_TRUE(c.is_extended && c.is_fd && c.esi);
    EXPECT_FALSE(c.is_rtr || c.is_error || c.brs);
    ASSERT_EQ(c.data.size(), 3u);
    EXPECT_EQ(std::to_integer<int>(c.data[2]), 0xff);
    for (std::size_t cut = 4; cut < can.size(); ++cut) {
      const Bytes part(can.begin(), can.begin() + static_cast<std::ptrdiff_t>(cut));
      EXPECT_NE(parse_cdr(*cdr_body(part), c), CdrStatus::kOk) << cut;
    }
  }
}

}  // namespace
}  // namespace sensor_rig::dds
