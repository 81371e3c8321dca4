// The payload sertype (dds/src/payload_sertype.c): chunk sizes equal to Cyclone's own for any
// sample of the types that use it, the same bytes on the wire and through shared memory, and
// interop with readers and writers that use Cyclone's default sertype in the same process.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <cstring>
#include <deque>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "sensor_rig/dds/payload_sertype.h"
#include "sensor_rig/dds/roudi.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/dds/view_reader.hpp"
#include "wait_bounds.hpp"

namespace sensor_rig::dds {
namespace {

// Strings and payload lengths that move every alignment boundary: empty, 1..9 characters, odd and
// fragment-sized payloads.
struct SampleMaker {
  std::mt19937 rng{1234};
  std::uint32_t r() { return static_cast<std::uint32_t>(rng()); }
  std::deque<std::string> strings;  // deque: pointers into earlier strings stay valid
  std::deque<std::vector<std::uint8_t>> payloads;
  std::deque<std::vector<msg::PointField>> field_lists;

  const char* text(std::size_t max_len) {
    std::uniform_int_distribution<std::size_t> len(0, max_len);
    std::string s(len(rng), 'a');
    for (auto& c : s) c = static_cast<char>('a' + r() % 26);
    strings.push_back(std::move(s));
    return strings.back().c_str();
  }
  dds_sequence_uint8 payload() {
    static constexpr std::size_t kLens[] = {0, 1, 2, 3, 5, 7, 8, 63, 64'001, 65'537};
    std::vector<std::uint8_t> b(kLens[r() % std::size(kLens)]);
    for (auto& x : b) x = static_cast<std::uint8_t>(rng());
    payloads.push_back(std::move(b));
    dds_sequence_uint8 s{};
    s._buffer = payloads.back().data();
    s._length = s._maximum = static_cast<std::uint32_t>(payloads.back().size());
    s._release = false;
    return s;
  }
  msg::PointCloud2 cloud() {
    msg::PointCloud2 pc{};
    pc.header.stamp = msg::to_time(static_cast<Nanos>(rng()));
    pc.header.frame_id = const_cast<char*>(text(9));
    pc.height = 1;
    pc.width = r() % 1000;
    std::vector<msg::PointField> fields(rng() % 5);
    for (auto& f : fields) {
      f.name = const_cast<char*>(text(6));
      f.offset = r() % 64;
      f.datatype = static_cast<std::uint8_t>(1 + r() % 8);
      f.count = 1;
    }
    field_lists.push_back(std::move(fields));
    pc.fields._buffer = field_lists.back().data();
    pc.fields._length = pc.fields._maximum = static_cast<std::uint32_t>(field_lists.back().size());
    pc.is_bigendian = (rng() & 1) != 0;
    pc.point_step = r() % 64;
    pc.row_step = r();
    pc.data = payload();
    pc.is_dense = (rng() & 1) != 0;
    return pc;
  }
  msg::Image image() {
    msg::Image im{};
    im.header.frame_id = const_cast<char*>(text(9));
    im.height = r() % 2000;
    im.width = r() % 2000;
    im.encoding = const_cast<char*>(text(9));
    im.is_bigendian = static_cast<std::uint8_t>(rng() & 1);
    im.step = r();
    im.data = payload();
    return im;
  }
  msg::CompressedImage compressed() {
    msg::CompressedImage ci{};
    ci.header.frame_id = const_cast<char*>(text(9));
    ci.format = const_cast<char*>(text(9));
    ci.data = payload();
    return ci;
  }
};

template <class T>
void expect_sizes_match(Participant& p, const T& sample, const char* what) {
  std::size_t ours = 0, cyclone = 0;
  ASSERT_EQ(rig_payload_sizes_for_test(p.handle(), TypeSupport<T>::descriptor(), "rt/test/payload/sizes",
                                       TypeSupport<T>::payload_offset, &sample, &ours, &cyclone),
            DDS_RETCODE_OK);
  EXPECT_EQ(ours, cyclone) << what;
}

TEST(PayloadSertype, ChunkSizeIsCyclonesOwnForEverySampleShape) {
  Participant p;
  SampleMaker m;
  for (int i = 0; i < 300; ++i) {
    expect_sizes_match(p, m.cloud(), "PointCloud2");
    expect_sizes_match(p, m.image(), "Image");
    expect_sizes_match(p, m.compressed(), "CompressedImage");
  }
}

TEST(PayloadSertype, TheEnvironmentSwitchGivesCyclonesSertype) {
  Participant p;
  SampleMaker m;
  const auto pc = m.cloud();
  ::setenv("RIG_DDS_DEFAULT_SERTYPE", "1", 1);
  std::size_t ours = 0, cyclone = 0;
  const int rc = rig_payload_sizes_for_test(p.handle(), TypeSupport<msg::PointCloud2>::descriptor(),
                                            "rt/test/payload/env", TypeSupport<msg::PointCloud2>::payload_offset, &pc,
                                            &ours, &cyclone);
  ::unsetenv("RIG_DDS_DEFAULT_SERTYPE");
  EXPECT_EQ(rc, DDS_RETCODE_UNSUPPORTED);
}

// One type, one payload offset: a second registration of the type with another offset (a caller's
// mistake) gets Cyclone's own sertype rather than a size computed at the wrong place.
TEST(PayloadSertype, AConflictingOffsetForTheSameTypeFallsBackToCyclonesSertype) {
  Participant p;
  SampleMaker m;
  const auto pc = m.cloud();
  std::size_t ours = 0, cyclone = 0;
  EXPECT_EQ(rig_payload_sizes_for_test(p.handle(), TypeSupport<msg::PointCloud2>::descriptor(), "rt/test/payload/a",
                                       TypeSupport<msg::PointCloud2>::payload_offset, &pc, &ours, &cyclone),
            DDS_RETCODE_OK);
  EXPECT_EQ(rig_payload_sizes_for_test(p.handle(), TypeSupport<msg::PointCloud2>::descriptor(), "rt/test/payload/b",
                                       offsetof(msg::PointCloud2, fields), &pc, &ours, &cyclone),
            DDS_RETCODE_UNSUPPORTED);
  // Writing through a topic created that way still works (Cyclone's sertype, Cyclone's size).
  Entity topic(check(rig_create_payload_topic(p.handle(), TypeSupport<msg::PointCloud2>::descriptor(),
                                              "rt/test/payload/b", nullptr, offsetof(msg::PointCloud2, fields)),
                     "rig_create_payload_topic"));
  Entity writer(check(dds_create_writer(p.handle(), topic.handle(), nullptr, nullptr), "dds_create_writer"));
  EXPECT_EQ(dds_write(writer.handle(), &pc), DDS_RETCODE_OK);
}

// memcmp with a null buffer is undefined even for 0 bytes (an empty payload has none).
bool same_bytes(const dds_sequence_uint8& a, const dds_sequence_uint8& b) {
  return a._length == b._length && (a._length == 0 || std::memcmp(a._buffer, b._buffer, a._length) == 0);
}

void expect_same_cloud(const msg::PointCloud2& a, const msg::PointCloud2& b) {
  EXPECT_STREQ(a.header.frame_id, b.header.frame_id);
  EXPECT_EQ(a.width, b.width);
  ASSERT_EQ(a.fields._length, b.fields._length);
  for (std::uint32_t i = 0; i < a.fields._length; ++i) {
    EXPECT_STREQ(a.fields._buffer[i].name, b.fields._buffer[i].name);
    EXPECT_EQ(a.fields._buffer[i].offset, b.fields._buffer[i].offset);
    EXPECT_EQ(a.fields._buffer[i].datatype, b.fields._buffer[i].datatype);
  }
  EXPECT_EQ(a.is_bigendian, b.is_bigendian);
  EXPECT_EQ(a.row_step, b.row_step);
  ASSERT_EQ(a.data._length, b.data._length);
  EXPECT_TRUE(same_bytes(a.data, b.data));
  EXPECT_EQ(a.is_dense, b.is_dense) << "the member after the payload";
}

// A plain Cyclone application (dds_create_topic: the default sertype) and the rig's topics in one
// process, each way round: Cyclone converts between the two sertypes; every byte arrives.
TEST(PayloadSertype, DefaultSertypeReadersAndWritersInTheSameProcessInteroperate) {
  Participant rig_side;
  Participant plain_side;
  const char* name = "rt/test/payload/interop";
  Topic<msg::PointCloud2> rig_topic(rig_side, "/test/payload/interop");
  Entity plain_topic(check(dds_create_topic(plain_side.handle(), TypeSupport<msg::PointCloud2>::descriptor(), name,
                                            nullptr, nullptr),
                           "dds_create_topic"));
  QosSpec q;
  q.depth = 16;
  auto qos = make_qos(q);
  Writer<msg::PointCloud2> rig_writer(rig_side, rig_topic, q);
  Reader<msg::PointCloud2> rig_reader(rig_side, rig_topic, q);
  Entity plain_reader(check(dds_create_reader(plain_side.handle(), plain_topic.handle(), qos.get(), nullptr), "reader"));
  Entity plain_writer(check(dds_create_writer(plain_side.handle(), plain_topic.handle(), qos.get(), nullptr), "writer"));
  ASSERT_TRUE(rig_writer.wait_for_readers(2, test::kDiscoveryMs));
  ASSERT_TRUE(wait_until([&] { return publication_matched(plain_writer.handle()) >= 2; }, test::kDiscoveryMs));

  SampleMaker m;
  std::vector<msg::PointCloud2> sent;
  for (int i = 0; i < 6; ++i) sent.push_back(m.cloud());
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(rig_writer.write(sent[i]).ok());
  for (int i = 3; i < 6; ++i) ASSERT_EQ(dds_write(plain_writer.handle(), &sent[i]), DDS_RETCODE_OK);

  // Every reader gets all six, in the order each writer wrote them.
  std::vector<int> rig_got;
  ASSERT_TRUE(wait_until(
      [&] {
        rig_reader.take([&](const msg::PointCloud2& s, const dds_sample_info_t&) {
          for (int i = 0; i < 6; ++i)
            if (std::strcmp(s.header.frame_id, sent[i].header.frame_id) == 0 && s.data._length == sent[i].data._length &&
                s.row_step == sent[i].row_step) {
              expect_same_cloud(s, sent[i]);
              rig_got.push_back(i);
              break;
            }
        });
        return rig_got.size() >= 6;
      },
      5000));
  std::vector<int> plain_got;
  ASSERT_TRUE(wait_until(
      [&] {
        void* ptrs[8] = {};
        dds_sample_info_t infos[8];
        const dds_return_t n = dds_take(plain_reader.handle(), ptrs, infos, 8, 8);
        for (dds_return_t k = 0; k < n; ++k) {
          if (!infos[k].valid_data) continue;
          const auto& s = *static_cast<const msg::PointCloud2*>(ptrs[k]);
          for (int i = 0; i < 6; ++i)
            if (s.row_step == sent[i].row_step && s.data._length == sent[i].data._length) {
              expect_same_cloud(s, sent[i]);
              plain_got.push_back(i);
              break;
            }
        }
        if (n > 0) dds_return_loan(plain_reader.handle(), ptrs, n);
        return plain_got.size() >= 6;
      },
      5000));
  EXPECT_EQ(rig_got.size(), 6u);
  EXPECT_EQ(plain_got.size(), 6u);
}

// The shared-memory round trip; what went wrong, in words ("" when nothing did).
std::string shm_round_trip() {
  DomainConfig cfg;
  cfg.domain_id = 97;
  cfg.transport = Transport::kShm;
  Participant writer_side(cfg);
  Participant reader_side(cfg);
  QosSpec q;
  q.depth = 16;
  Topic<msg::PointCloud2> wt(writer_side, "/test/payload/shm", q);
  Topic<msg::PointCloud2> rt(reader_side, "/test/payload/shm", q);
  Writer<msg::PointCloud2> writer(writer_side, wt, q);
  Reader<msg::PointCloud2> reader(reader_side, rt, q);
  Reader<msg::PointCloud2> serialized(reader_side, rt, q);
  if (!writer.wait_for_readers(2, test::kDiscoveryMs)) return "readers not matched";
  SampleMaker m;
  std::vector<msg::PointCloud2> sent;
  for (int i = 0; i < 12; ++i) {
    sent.push_back(m.cloud());
    if (!writer.write(sent.back()).ok()) return "write " + std::to_string(i) + " failed";
  }
  std::size_t got = 0;
  std::string problems;
  wait_until(
      [&] {
        reader.take([&](const msg::PointCloud2& s, const dds_sample_info_t&) {
          if (got < sent.size()) {
            const auto& e = sent[got];
            if (std::strcmp(s.header.frame_id, e.header.frame_id) != 0 || s.fields._length != e.fields._length ||
                s.row_step != e.row_step || s.data._length != e.data._length ||
                !same_bytes(s.data, e.data) || s.is_dense != e.is_dense)
              problems += "sample " + std::to_string(got) + " differs; ";
          }
          ++got;
        });
        return got >= sent.size();
      },
      5000);
  if (got != sent.size()) problems += "received " + std::to_string(got) + " of " + std::to_string(sent.size()) + "; ";
  std::size_t taken = 0, in_chunk = 0;
  SerializedSample sample;
  while (take_serialized(serialized.handle(), sample)) {
    ++taken;
    if (sample.in_shared_memory()) ++in_chunk;
  }
  sample.reset();
  if (taken != sent.size() || in_chunk != taken)
    problems += std::to_string(in_chunk) + " of " + std::to_string(taken) + " taken samples in iceoryx chunks; ";
  return problems;
}

// Over shared memory each sample is serialized into a chunk of the size this sertype computes (a
// chunk too short fails the write): a reader in another participant gets every member back, the
// one after the payload too, and a second reader sees that they came in iceoryx chunks. In a
// child process: RouDi sends SIGTERM to every process still registered with it when it stops,
// and Cyclone's iceoryx runtime stays registered until its process exits.
TEST(PayloadSertype, SharedMemoryChunksCarryEveryByte) {
  if (::access("/usr/bin/iox-roudi", X_OK) != 0) GTEST_SKIP() << "no iox-roudi (Debian package iceoryx)";
  if (probe_roudi().pid != 0) GTEST_SKIP() << "another RouDi runs on this machine; this test needs its own";
  char dir[] = "/tmp/rig-payload-XXXXXX";
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
