// The MCAP writer against its own reader and against @mcap/core (tests/js/mcap_dump.mjs, an
// implementation written by others that also decodes the CDR with the file's ros2msg schema): each
// compression, split files, a file cut anywhere (a killed writer), a corrupt chunk, wrong magic,
// a full disk.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "rig_process.hpp"
#include "sensor_rig/msgs/ros2msg.hpp"
#include <yaml-cpp/yaml.h>

#include "sensor_rig/record/mcap_reader.hpp"
#include "sensor_rig/record/mcap_repair.hpp"
#include "sensor_rig/record/mcap_writer.hpp"
#include "sensor_rig/record/split_writer.hpp"
#include "test_data.hpp"

namespace sensor_rig::record {
namespace {

std::uint32_t fnv1a(std::span<const std::byte> b) {
  std::uint32_t h = 0x811c9dc5u;
  for (const auto x : b) h = (h ^ std::to_integer<std::uint32_t>(x)) * 0x01000193u;
  return h;
}

// A little-endian XCDR1 sensor_msgs/CompressedImage: header (stamp, frame_id), format, data.
std::vector<std::byte> compressed_image_cdr(int i, std::vector<std::byte>& payload) {
  std::vector<std::byte> b = {std::byte{0}, std::byte{1}, std::byte{0}, std::byte{0}};
  const auto u32 = [&](std::uint32_t v) {
    while ((b.size() - 4) % 4 != 0) b.push_back(std::byte{0});
    for (int k = 0; k < 4; ++k) b.push_back(static_cast<std::byte>((v >> (8 * k)) & 0xff));
  };
  const auto str = [&](const std::string& s) {
    u32(static_cast<std::uint32_t>(s.size() + 1));
    for (char c : s) b.push_back(static_cast<std::byte>(c));
    b.push_back(std::byte{0});
  };
  u32(1'700'000'000u + static_cast<std::uint32_t>(i));
  u32(static_cast<std::uint32_t>(i) * 1000u);
  str("cam_" + std::to_string(i % 3));
  str("jpeg");
  payload.resize(100 + static_cast<std::size_t>(i) * 37 % 5000);
  for (std::size_t k = 0; k < payload.size(); ++k) payload[k] = static_cast<std::byte>((k * 7 + static_cast<std::size_t>(i)) & 0xff);
  u32(static_cast<std::uint32_t>(payload.size()));
  b.insert(b.end(), payload.begin(), payload.end());
  return b;
}

struct Sent {
  std::vector<std::vector<std::byte>> cdr;
  std::vector<std::uint32_t> payload_fnv;
};

constexpr int kN = 300;

Sent write_file(const std::string& path, Compression c, std::size_t chunk_size = 64 * 1024) {
  McapWriterOptions o;
  o.compression = c;
  o.chunk_size = chunk_size;
  McapWriter w(path, o);
  const std::string schema = *msgs::ros2msg_schema("sensor_msgs/msg/CompressedImage");
  const auto sid = w.add_schema("sensor_msgs/msg/CompressedImage", "ros2msg", schema);
  const auto ch_a = w.add_channel(sid, "/cam/a", "cdr", {{"offered_qos_profiles", "- history: 1\n"}});
  const auto ch_b = w.add_channel(sid, "/cam/b", "cdr", {});
  Sent s;
  for (int i = 0; i < kN; ++i) {
    std::vector<std::byte> payload;
    s.cdr.push_back(compressed_image_cdr(i, payload));
    s.payload_fnv.push_back(fnv1a(payload));
    const std::span<const std::byte> whole(s.cdr.back());
    // Two pieces, as a shared-memory sample arrives (header made, members in the chunk).
    const std::span<const std::byte> pieces[] = {whole.first(4), whole.subspan(4)};
    w.write(i % 2 == 0 ? ch_a : ch_b, static_cast<std::uint32_t>(i), 1'000'000'000ull + static_cast<std::uint64_t>(i) * 1000,
            500'000'000ull + static_cast<std::uint64_t>(i), pieces);
  }
  w.close();
  return s;
}

nlohmann::json node_dump(const std::string& file) {
  const auto script = test::source_dir() / "tests/js/mcap_dump.mjs";
  const auto [rc, out] = test::run("node " + script.string() + " " + file + " 2>&1");
  EXPECT_EQ(rc, 0) << out;
  return nlohmann::json::parse(out, nullptr, false);
}

class McapEachCompression : public ::testing::TestWithParam<Compression> {};

TEST_P(McapEachCompression, OurReaderAndMcapCoreReadWhatWasWritten) {
  test::TempDir dir;
  const std::string file = (dir.path / "t.mcap").string();
  const Sent sent = write_file(file, GetParam());

  McapReader r(file);
  EXPECT_TRUE(r.complete());
  EXPECT_TRUE(r.problems().empty());
  EXPECT_EQ(r.profile(), "ros2");
  ASSERT_EQ(r.channels().size(), 2u);
  EXPECT_GT(r.chunk_count(), 5u);
  int i = 0;
  r.for_each_message([&](const McapMessage& m) {
    EXPECT_EQ(m.sequence, static_cast<std::uint32_t>(i));
    EXPECT_EQ(m.log_time, 1'000'000'000ull + static_cast<std::uint64_t>(i) * 1000);
    EXPECT_EQ(m.publish_time, 500'000'000ull + static_cast<std::uint64_t>(i));
    EXPECT_TRUE(std::equal(m.data.begin(), m.data.end(), sent.cdr[static_cast<std::size_t>(i)].begin(),
                           sent.cdr[static_cast<std::size_t>(i)].end()));
    ++i;
    return true;
  });
  EXPECT_EQ(i, kN);

  const auto j = node_dump(file);
  ASSERT_FALSE(j.is_discarded());
  ASSERT_FALSE(j.contains("error")) << j.dump();
  EXPECT_EQ(j["profile"], "ros2");
  EXPECT_EQ(j["channels"]["/cam/a"]["schema"], "sensor_msgs/msg/CompressedImage");
  EXPECT_EQ(j["channels"]["/cam/a"]["schema_encoding"], "ros2msg");
  EXPECT_EQ(j["channels"]["/cam/a"]["message_encoding"], "cdr");
  EXPECT_EQ(j["channels"]["/cam/a"]["metadata"]["offered_qos_profiles"], "- history: 1\n");
  EXPECT_EQ(j["channels"]["/cam/a"]["count"], kN / 2);
  EXPECT_EQ(j["statistics"]["message_count"], std::to_string(kN));
  EXPECT_EQ(j["streamed"], kN);
  EXPECT_EQ(j["stream_complete"], true);
  EXPECT_EQ(j["undecodable"], 0);
  ASSERT_EQ(j["messages"].size(), static_cast<std::size_t>(kN));
  for (int k = 0; k < kN; ++k) {
    const auto& m = j["messages"][static_cast<std::size_t>(k)];
    EXPECT_EQ(m["topic"], k % 2 == 0 ? "/cam/a" : "/cam/b");
    EXPECT_EQ(m["stamp_ns"], std::to_string((1'700'000'000ll + k) * 1'000'000'000ll + k * 1000));
    EXPECT_EQ(m["frame_id"], "cam_" + std::to_string(k % 3));
    EXPECT_EQ(m["format"], "jpeg");
    EXPECT_EQ(m["data_fnv"], sent.payload_fnv[static_cast<std::size_t>(k)]);
  }
}

INSTANTIATE_TEST_SUITE_P(All, McapEachCompression,
                         ::testing::Values(Compression::kNone, Compression::kLz4, Compression::kZstd));

TEST(McapReader, ACutFileReadsEveryChunkBeforeTheCut) {
  test::TempDir dir;
  const std::string file = (dir.path / "t.mcap").string();
  write_file(file, Compression::kZstd, 16 * 1024);
  std::vector<std::uint64_t> chunk_ends;  // file offset after each chunk's message indexes
  std::vector<int> messages_before;       // messages in chunks completed by then
  {
    McapReader r(file);
    ASSERT_TRUE(r.complete());
  }
  const auto size = std::filesystem::file_size(file);
  std::ifstream in(file, std::ios::binary);
  std::vector<char> all(size);
  in.read(all.data(), static_cast<std::streamsize>(size));
  // Cut at 17 places across the file: each prefix reads without throwing, names the offset where it
  // stops, and its messages are exactly a prefix of what was written.
  std::uint64_t last_count = 0;
  for (int k = 1; k <= 17; ++k) {
    const auto cut = size * static_cast<std::uint64_t>(k) / 18;
    const std::string part = (dir.path / ("cut" + std::to_string(k) + ".mcap")).string();
    std::ofstream(part, std::ios::binary).write(all.data(), static_cast<std::streamsize>(cut));
    McapReader r(part);
    EXPECT_FALSE(r.complete());
    ASSERT_FALSE(r.problems().empty());
    EXPECT_NE(r.problems().front().what.find("truncated"), std::string::npos) << r.problems().front().what;
    EXPECT_LE(r.problems().front().offset, cut);
    std::uint32_t expect_seq = 0;
    const auto n = r.for_each_message([&](const McapMessage& m) {
      EXPECT_EQ(m.sequence, expect_seq++);
      return true;
    });
    EXPECT_GE(n, last_count);  // a longer prefix never reads less
    last_count = n;
  }
  EXPECT_GT(last_count, static_cast<std::uint64_t>(kN) * 3 / 4);
}

TEST(McapReader, ACorruptChunkIsSkippedByNameAndTheRestPlays) {
  for (const auto c : {Compression::kNone, Compression::kZstd}) {
    test::TempDir dir;
    const std::string file = (dir.path / "t.mcap").string();
    write_file(file, c, 16 * 1024);
    std::uint64_t total = 0;
    {
      McapReader r(file);
      total = r.for_each_message([](const McapMessage&) { return true; });
    }
    // Flip one byte in the middle of the file (inside some chunk's records).
    const auto size = std::filesystem::file_size(file);
    {
      std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
      f.seekg(static_cast<std::streamoff>(size / 2));
      char b = 0;
      f.read(&b, 1);
      f.seekp(static_cast<std::streamoff>(size / 2));
      b = static_cast<char>(b ^ 0x5a);
      f.write(&b, 1);
    }
    McapReader r(file);
    const auto n = r.for_each_message([](const McapMessage&) { return true; });
    ASSERT_EQ(r.problems().size(), 1u) << mcap_name(c);
    EXPECT_TRUE(r.problems()[0].what.find("CRC mismatch") != std::string::npos ||
                r.problems()[0].what.find("does not decompress") != std::string::npos)
        << r.problems()[0].what;
    EXPECT_LT(r.problems()[0].offset, size / 2);
    EXPECT_LT(n, total);
    EXPECT_GT(n, total / 2);
  }
}

TEST(McapReader, RefusesWhatIsNotMcap) {
  test::TempDir dir;
  const auto bad = dir.write("bad.mcap", "\x89MCAQ0\r\nxxxxxxxxxxxxxxxxxxxxxx");
  try {
    McapReader r(bad);
    FAIL() << "accepted wrong magic";
  } catch (const McapError& e) {
    EXPECT_NE(std::string(e.what()).find("wrong magic at offset 0"), std::string::npos) << e.what();
  }
  EXPECT_THROW(McapReader(dir.write("short.mcap", "\x89MC")), McapError);
  EXPECT_THROW(McapReader((dir.path / "missing.mcap").string()), McapError);
}

TEST(McapWriter, AFullDiskIsAnErrorWithTheReason) {
  McapWriterOptions o;
  o.chunk_size = 1024;
  try {
    McapWriter w("/dev/full", o);
    const std::byte data[2048] = {};
    const std::span<const std::byte> pieces[] = {data};
    w.write(w.add_channel(w.add_schema("a/msg/B", "ros2msg", "uint8 x\n"), "/t", "cdr", {}), 0, 1, 1, pieces);
    FAIL() << "wrote to /dev/full";
  } catch (const McapError& e) {
    EXPECT_NE(std::string(e.what()).find("No space left on device"), std::string::npos) << e.what();
  }
}

TEST(SplitWriter, SplitsBySizeIntoCompleteFiles) {
  test::TempDir dir;
  SplitOptions o;
  o.out = (dir.path / "rec").string();
  o.split_bytes = 40 * 1024;
  o.mcap.chunk_size = 8 * 1024;
  o.mcap.compression = Compression::kNone;  // sizes as written: the split points are predictable
  SplitWriter w(o);
  const auto ch = w.add_channel({"/cam/a", "sensor_msgs/msg/CompressedImage", "ros2msg",
                                 *msgs::ros2msg_schema("sensor_msgs/CompressedImage"), "cdr", {}});
  for (int i = 0; i < kN; ++i) {
    std::vector<std::byte> payload;
    const auto cdr = compressed_image_cdr(i, payload);
    const std::span<const std::byte> pieces[] = {cdr};
    w.write(ch, static_cast<std::uint64_t>(i), static_cast<std::uint64_t>(i), pieces);
  }
  w.close();
  ASSERT_GT(w.files().size(), 3u);
  EXPECT_EQ(std::filesystem::path(w.files()[0]).filename(), "rec_0.mcap");
  std::uint64_t total = 0;
  std::uint32_t seq = 0;
  for (const auto& f : w.files()) {
    McapReader r(f);
    EXPECT_TRUE(r.complete()) << f;
    EXPECT_EQ(r.channels().size(), 1u);
    total += r.for_each_message([&](const McapMessage& m) {
      EXPECT_EQ(m.sequence, seq++);
      return true;
    });
  }
  EXPECT_EQ(total, static_cast<std::uint64_t>(kN));
  EXPECT_THROW(SplitWriter{o}, McapError);  // the folder is not empty any more
}

TEST(SplitWriter, SplitsByLogTime) {
  test::TempDir dir;
  SplitOptions o;
  o.out = (dir.path / "rec").string();
  o.split_ns = 1'000'000'000;  // 1 s of log time per file
  o.mcap.compression = Compression::kZstd;
  SplitWriter w(o);
  const auto a = w.add_channel({"/cam/a", "sensor_msgs/msg/CompressedImage", "ros2msg",
                                *msgs::ros2msg_schema("sensor_msgs/CompressedImage"), "cdr", {}});
  const auto b = w.add_channel({"/cam/b", "sensor_msgs/msg/CompressedImage", "ros2msg",
                                *msgs::ros2msg_schema("sensor_msgs/CompressedImage"), "cdr", {}});
  // 50 messages 100 ms apart: 5 s -> files [0,1) [1,2) ... [4,5) s.
  for (int i = 0; i < 50; ++i) {
    std::vector<std::byte> payload;
    const auto cdr = compressed_image_cdr(i, payload);
    const std::span<const std::byte> pieces[] = {cdr};
    w.write(i < 25 ? a : b, 5'000'000'000ull + static_cast<std::uint64_t>(i) * 100'000'000, 0, pieces);
  }
  w.close();
  ASSERT_EQ(w.files().size(), 5u);
  for (std::size_t f = 0; f < 5; ++f) {
    McapReader r(w.files()[f]);
    EXPECT_TRUE(r.complete());
    std::uint64_t lo = UINT64_MAX, hi = 0;
    const auto n = r.for_each_message([&](const McapMessage& m) {
      lo = std::min(lo, m.log_time);
      hi = std::max(hi, m.log_time);
      return true;
    });
    EXPECT_EQ(n, 10u) << f;
    EXPECT_EQ(lo, 5'000'000'000ull + f * 1'000'000'000ull);
    EXPECT_LT(hi - lo, 1'000'000'000ull);
    // Only the channels this file carries: /cam/a up to 2.4 s, /cam/b from 2.5 s.
    EXPECT_EQ(r.channels().size(), f == 2 ? 2u : 1u) << f;
  }
}

// tests/js/mcap_messages.mjs: every message as @mcap/core's indexed or stream reader has it.
nlohmann::json node_messages(const std::string& file, const char* mode) {
  const auto script = test::source_dir() / "tests/js/mcap_messages.mjs";
  const auto [rc, out] = test::run("node " + script.string() + " " + file + " " + mode + " 2>&1");
  auto j = nlohmann::json::parse(out, nullptr, false);
  if (rc != 0 || j.is_discarded()) return nlohmann::json{{"error", "exit " + std::to_string(rc) + ": " + out}};
  return j;
}

std::vector<char> read_all(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The repaired file, read by @mcap/core's indexed reader (it needs the summary, the chunk indexes and
// the message indexes repair wrote), holds exactly the messages @mcap/core's stream reader takes from
// the damaged input before the damage, byte for byte, and they are what was written.
void expect_repaired_equals_intact_prefix(const std::string& damaged, const std::string& repaired, const Sent& sent,
                                          const RepairResult& r) {
  const auto truth = node_messages(damaged, "stream");
  const auto got = node_messages(repaired, "indexed");
  ASSERT_FALSE(truth.contains("error")) << truth.dump();
  ASSERT_FALSE(got.contains("error")) << got.dump();
  EXPECT_NE(truth["stopped"], "") << "the stream reader read the damaged file to its end";
  ASSERT_EQ(got["count"], truth["count"]);
  EXPECT_EQ(r.messages, truth["count"].get<std::uint64_t>());
  EXPECT_EQ(got["statistics"]["message_count"], std::to_string(r.messages));
  EXPECT_EQ(got["statistics"]["chunk_count"], r.chunks);
  EXPECT_EQ(got["chunk_indexes"], r.chunks);
  // The stream has each chunk's messages in record order, the indexed reader in log-time order:
  // both are sequence order here (log time grows with the sequence).
  for (std::size_t k = 0; k < got["messages"].size(); ++k) {
    const auto& a = got["messages"][k];
    EXPECT_EQ(a, truth["messages"][k]) << k;
    const auto seq = a["sequence"].get<std::size_t>();
    ASSERT_LT(seq, sent.cdr.size());
    std::vector<std::byte> cdr = sent.cdr[seq];
    EXPECT_EQ(a["fnv"], fnv1a(cdr)) << seq;
  }
}

TEST(McapRepair, ACutFileBecomesCompleteWithEveryIntactChunk) {
  for (const auto c : {Compression::kLz4, Compression::kZstd}) {
    test::TempDir dir;
    const std::string file = (dir.path / "t.mcap").string();
    const Sent sent = write_file(file, c, 16 * 1024);
    const auto all = read_all(file);
    std::uint64_t last = 0;
    for (int k = 1; k <= 5; ++k) {
      const auto cut = all.size() * static_cast<std::size_t>(k) / 6 + 13;  // inside a record, not at its start
      SCOPED_TRACE(std::string(mcap_name(c)) + " cut at " + std::to_string(cut));
      const std::string part = (dir.path / ("cut" + std::to_string(k) + ".mcap")).string();
      const std::string fixed = (dir.path / ("fixed" + std::to_string(k) + ".mcap")).string();
      std::ofstream(part, std::ios::binary).write(all.data(), static_cast<std::streamsize>(cut));
      const RepairResult r = repair_mcap(part, fixed);
      EXPECT_TRUE(r.cut) << r.damage;
      EXPECT_FALSE(r.had_summary);
      EXPECT_NE(r.damage.find("runs past the end of the file (" + std::to_string(cut) + " bytes)"), std::string::npos) << r.damage;
      EXPECT_NE(r.damage.find("at offset " + std::to_string(r.stopped_at)), std::string::npos) << r.damage;
      EXPECT_LT(r.stopped_at, cut);
      EXPECT_EQ(r.channels, 2u);
      EXPECT_GE(r.messages, last);
      last = r.messages;
      expect_repaired_equals_intact_prefix(part, fixed, sent, r);
      McapReader ours(fixed);
      EXPECT_TRUE(ours.complete());
      EXPECT_TRUE(ours.problems().empty());
    }
    EXPECT_GT(last, static_cast<std::uint64_t>(kN) * 3 / 4);
  }
}

TEST(McapRepair, ACorruptChunkStopsThereNamingItsOffset) {
  for (const auto c : {Compression::kNone, Compression::kZstd}) {
    SCOPED_TRACE(std::string(mcap_name(c)));
    test::TempDir dir;
    const std::string file = (dir.path / "t.mcap").string();
    const Sent sent = write_file(file, c, 16 * 1024);
    const auto size = std::filesystem::file_size(file);
    const auto flip = size / 2;
    {
      std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
      f.seekg(static_cast<std::streamoff>(flip));
      char b = 0;
      f.read(&b, 1);
      f.seekp(static_cast<std::streamoff>(flip));
      b = static_cast<char>(b ^ 0x5a);
      f.write(&b, 1);
    }
    const std::string fixed = (dir.path / "fixed.mcap").string();
    const RepairResult r = repair_mcap(file, fixed);
    EXPECT_FALSE(r.cut);
    EXPECT_TRUE(r.damage.find("CRC mismatch") != std::string::npos || r.damage.find("does not decompress") != std::string::npos)
        << r.damage;
    EXPECT_NE(r.damage.find("Chunk at offset " + std::to_string(r.stopped_at)), std::string::npos) << r.damage;
    // The named chunk holds the flipped byte.
    const auto all = read_all(file);
    std::uint64_t len = 0;
    for (int i = 0; i < 8; ++i) len |= static_cast<std::uint64_t>(static_cast<unsigned char>(all[r.stopped_at + 1 + static_cast<std::size_t>(i)])) << (8 * i);
    EXPECT_EQ(all[r.stopped_at], 0x06);
    EXPECT_LT(r.stopped_at, flip);
    EXPECT_GE(r.stopped_at + 9 + len, flip);
    expect_repaired_equals_intact_prefix(file, fixed, sent, r);
  }
}

TEST(McapRepair, RefusesWhatIsNotMcapAndReadsACompleteFileWhole) {
  test::TempDir dir;
  const std::string out = (dir.path / "out.mcap").string();
  try {
    repair_mcap(dir.write("bad.mcap", "\x89MCAQ0\r\nxxxxxxxxxxxxxxxxxxxxxx"), out);
    FAIL() << "accepted wrong magic";
  } catch (const McapError& e) {
    EXPECT_NE(std::string(e.what()).find("wrong magic at offset 0"), std::string::npos) << e.what();
  }
  const std::string file = (dir.path / "t.mcap").string();
  write_file(file, Compression::kZstd);
  const RepairResult r = repair_mcap(file, out);
  EXPECT_TRUE(r.had_summary);
  EXPECT_TRUE(r.damage.empty()) << r.damage;
  EXPECT_EQ(r.messages, static_cast<std::uint64_t>(kN));
  const auto a = node_messages(file, "indexed");
  const auto b = node_messages(out, "indexed");
  ASSERT_FALSE(b.contains("error")) << b.dump();
  EXPECT_EQ(a["messages"], b["messages"]);
  EXPECT_EQ(a["statistics"], b["statistics"]);
}

// A split folder's metadata.yaml, parsed by yaml-cpp: rosbag2's structure (version 5), and every
// count and time equal to what @mcap/core reads in the files it names.
TEST(SplitWriter, MetadataYamlIsRosbag2sAndMatchesEachFile) {
  test::TempDir dir;
  SplitOptions o;
  o.out = (dir.path / "rec").string();
  o.split_bytes = 40 * 1024;
  o.mcap.chunk_size = 8 * 1024;
  o.mcap.compression = Compression::kNone;  // sizes as written: several files
  SplitWriter w(o);
  const std::string qos = "- history: 1\n  depth: 5\n  reliability: 2\n";
  const auto a = w.add_channel({"/cam/a", "sensor_msgs/msg/CompressedImage", "ros2msg",
                                *msgs::ros2msg_schema("sensor_msgs/CompressedImage"), "cdr", {{"offered_qos_profiles", qos}}});
  const auto b = w.add_channel({"/cam/b", "sensor_msgs/msg/CompressedImage", "ros2msg",
                                *msgs::ros2msg_schema("sensor_msgs/CompressedImage"), "cdr", {{"offered_qos_profiles", qos}}});
  for (int i = 0; i < kN; ++i) {
    std::vector<std::byte> payload;
    const auto cdr = compressed_image_cdr(i, payload);
    const std::span<const std::byte> pieces[] = {cdr};
    w.write(i % 3 == 0 ? a : b, 1'000'000'000ull + static_cast<std::uint64_t>(i) * 7'000'000, 0, pieces);
  }
  w.close();
  ASSERT_GT(w.files().size(), 3u);

  const YAML::Node root = YAML::LoadFile((dir.path / "rec" / "metadata.yaml").string());
  const YAML::Node m = root["rosbag2_bagfile_information"];
  ASSERT_TRUE(m.IsMap());
  EXPECT_EQ(m["version"].as<int>(), 5);
  EXPECT_EQ(m["storage_identifier"].as<std::string>(), "mcap");
  EXPECT_EQ(m["compression_format"].as<std::string>(), "");
  EXPECT_EQ(m["compression_mode"].as<std::string>(), "");
  ASSERT_EQ(m["relative_file_paths"].size(), w.files().size());
  ASSERT_EQ(m["files"].size(), w.files().size());
  std::uint64_t total = 0, first = UINT64_MAX, last = 0;
  std::map<std::string, std::uint64_t> per_topic;
  for (std::size_t f = 0; f < w.files().size(); ++f) {
    SCOPED_TRACE(w.files()[f]);
    const std::string name = std::filesystem::path(w.files()[f]).filename().string();
    EXPECT_EQ(m["relative_file_paths"][f].as<std::string>(), name);
    const YAML::Node fi = m["files"][f];
    EXPECT_EQ(fi["path"].as<std::string>(), name);
    const auto j = node_messages(w.files()[f], "indexed");
    ASSERT_FALSE(j.contains("error")) << j.dump();
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
  EXPECT_EQ(total, static_cast<std::uint64_t>(kN));
  EXPECT_EQ(m["message_count"].as<std::uint64_t>(), total);
  EXPECT_EQ(m["starting_time"]["nanoseconds_since_epoch"].as<std::uint64_t>(), first);
  EXPECT_EQ(m["duration"]["nanoseconds"].as<std::uint64_t>(), last - first);
  ASSERT_EQ(m["topics_with_message_count"].size(), 2u);
  for (const auto& t : m["topics_with_message_count"]) {
    const std::string name = t["topic_metadata"]["name"].as<std::string>();
    EXPECT_EQ(t["topic_metadata"]["type"].as<std::string>(), "sensor_msgs/msg/CompressedImage");
    EXPECT_EQ(t["topic_metadata"]["serialization_format"].as<std::string>(), "cdr");
    EXPECT_EQ(t["topic_metadata"]["offered_qos_profiles"].as<std::string>(), qos);
    EXPECT_EQ(t["message_count"].as<std::uint64_t>(), per_topic[name]) << name;
  }
  EXPECT_EQ(per_topic["/cam/a"], static_cast<std::uint64_t>(kN / 3));
}

}  // namespace
}  // namespace sensor_rig::record
