// The chunk values of a multipart buffer (issue 27 items 3 and 9; camera/src/chunk_layout.hpp):
// each feature's place resolved from GenICam nodes as Aravis parses them, then read from a chunk
// part built here byte by byte. Ground truth: the bytes this test wrote and the XML it gave. The
// fake GigE camera's own XML is resolved too (its chunk ids are those its GVSP reshaper sends).
#include "chunk_layout.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

#include "sensor_rig/camera/mock/fake_cameras.hpp"

namespace sensor_rig::camera::detail {

// How gtest shows a field (found by ADL: beside ChunkField, not in the anonymous namespace).
void PrintTo(const ChunkField& f, std::ostream* os) {
  *os << "{chunk " << std::hex << f.chunk_id << std::dec << ", offset " << f.offset << ", " << f.length << " bytes, "
      << (f.big_endian ? "big" : "little") << " endian, " << (f.is_float ? "float" : f.is_signed ? "signed" : "unsigned") << "}";
}

namespace {

// A chunk part: each chunk's data, then its id and length (big endian), in order.
struct Part {
  std::vector<std::uint8_t> bytes;
  Part& add(std::uint32_t id, const std::vector<std::uint8_t>& data) {
    bytes.insert(bytes.end(), data.begin(), data.end());
    for (const std::uint32_t v : {id, static_cast<std::uint32_t>(data.size())})
      for (int i = 3; i >= 0; --i) bytes.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
    return *this;
  }
};

std::vector<std::uint8_t> big_endian(std::uint64_t v, int bytes) {
  std::vector<std::uint8_t> out;
  for (int i = bytes - 1; i >= 0; --i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  return out;
}

TEST(ChunkWalk, EveryChunkIsFoundWhereItWasWritten) {
  Part p;
  p.add(0x11, {1, 2, 3}).add(0x22, big_endian(0x0102030405060708u, 8)).add(0x33, {});
  const auto a = find_chunk(p.bytes.data(), p.bytes.size(), 0x11);
  ASSERT_TRUE(a);
  EXPECT_EQ(a->data, p.bytes.data());
  EXPECT_EQ(a->size, 3u);
  const auto b = find_chunk(p.bytes.data(), p.bytes.size(), 0x22);
  ASSERT_TRUE(b);
  EXPECT_EQ(b->data, p.bytes.data() + 3 + 8);
  EXPECT_EQ(b->size, 8u);
  const auto c = find_chunk(p.bytes.data(), p.bytes.size(), 0x33);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->size, 0u);
  EXPECT_FALSE(find_chunk(p.bytes.data(), p.bytes.size(), 0x44));
  EXPECT_FALSE(find_chunk(nullptr, 0, 0x11));
  EXPECT_FALSE(find_chunk(p.bytes.data(), 7, 0x11)) << "shorter than a tag";
}

// One flipped byte in a length: the walk stops there instead of reading at a guessed place.
TEST(ChunkWalk, ALengthThatDoesNotAddUpStopsTheWalk) {
  Part p;
  p.add(0x11, big_endian(42, 8)).add(0x22, big_endian(7, 8));
  auto corrupt = p.bytes;
  corrupt[corrupt.size() - 4] ^= 0x40;  // the last chunk's length: 8 -> 0x40000008
  EXPECT_FALSE(find_chunk(corrupt.data(), corrupt.size(), 0x22));
  EXPECT_FALSE(find_chunk(corrupt.data(), corrupt.size(), 0x11)) << "walked past a length that does not add up";
  // Truncated by one byte: the tags are read one byte off and no longer add up.
  EXPECT_FALSE(find_chunk(p.bytes.data(), p.bytes.size() - 1, 0x11));
}

TEST(ChunkValue, IntegersInEitherByteOrderAndSign) {
  Part p;
  p.add(1, {0xde, 0xad, 0xff, 0xff, 0xff, 0xfe, 0x01, 0x02});
  const auto chunk = find_chunk(p.bytes.data(), p.bytes.size(), 1);
  ASSERT_TRUE(chunk);
  ChunkField f{.chunk_id = 1, .offset = 2, .length = 4, .big_endian = true, .is_float = false, .is_signed = true};
  EXPECT_EQ(read_integer(*chunk, f), -2);
  f.is_signed = false;
  EXPECT_EQ(read_integer(*chunk, f), 0xfffffffe);
  f.big_endian = false;  // bytes ff ff ff fe read little endian: 0xfeffffff
  EXPECT_EQ(read_integer(*chunk, f), 0xfeffffff);
  f.is_signed = true;
  EXPECT_EQ(read_integer(*chunk, f), static_cast<std::int32_t>(0xfeffffffu));
  f = {.chunk_id = 1, .offset = 0, .length = 8, .big_endian = true, .is_float = false, .is_signed = false};
  EXPECT_EQ(read_integer(*chunk, f), static_cast<std::int64_t>(0xdeadfffffffe0102u));
  f.length = 2;
  f.offset = 6;
  EXPECT_EQ(read_integer(*chunk, f), 0x0102);
  EXPECT_EQ(read_float(*chunk, f), 258.0) << "an integer field read as a float";
}

TEST(ChunkValue, BytesOutsideTheChunkAreNotRead) {
  Part p;
  p.add(1, {1, 2, 3, 4}).add(2, {5, 6, 7, 8});
  const auto chunk = find_chunk(p.bytes.data(), p.bytes.size(), 1);
  ASSERT_TRUE(chunk);
  ChunkField f{.chunk_id = 1, .offset = 2, .length = 4, .big_endian = true, .is_float = false, .is_signed = false};
  EXPECT_FALSE(read_integer(*chunk, f)) << "two bytes of the chunk's tag read as its value";
  f.offset = 1ull << 62;  // no wrap-around
  EXPECT_FALSE(read_integer(*chunk, f));
  f = {.chunk_id = 1, .offset = 0, .length = 0, .big_endian = true, .is_float = false, .is_signed = false};
  EXPECT_FALSE(read_integer(*chunk, f));
  f.length = 3;
  f.is_float = true;  // not IEEE 754
  EXPECT_FALSE(read_float(*chunk, f));
}

TEST(ChunkValue, FloatsOfFourAndEightBytes) {
  Part p;
  p.add(7, big_endian(std::bit_cast<std::uint64_t>(12345.678), 8));
  p.add(8, big_endian(std::bit_cast<std::uint32_t>(2500.5f), 4));
  const auto d = find_chunk(p.bytes.data(), p.bytes.size(), 7);
  const auto s = find_chunk(p.bytes.data(), p.bytes.size(), 8);
  ASSERT_TRUE(d && s);
  const ChunkField wide{.chunk_id = 7, .offset = 0, .length = 8, .big_endian = true, .is_float = true, .is_signed = false};
  const ChunkField narrow{.chunk_id = 8, .offset = 0, .length = 4, .big_endian = true, .is_float = true, .is_signed = false};
  EXPECT_EQ(read_float(*d, wide), 12345.678);
  EXPECT_EQ(read_float(*s, narrow), 2500.5);
  EXPECT_EQ(read_integer(*d, wide), 12346) << "a float field read as an integer is rounded";
  ChunkField swapped = wide;
  swapped.big_endian = false;
  EXPECT_NE(read_float(*d, swapped), 12345.678);
}

// GenICam parsed by Aravis (arv_gc_new, no device: nothing is read from one).
class ChunkResolve : public ::testing::Test {
 protected:
  void parse(const std::string& xml) {
    gc_ = arv_gc_new(nullptr, xml.data(), xml.size());
    ASSERT_NE(gc_, nullptr);
  }
  void TearDown() override {
    if (gc_ != nullptr) g_object_unref(gc_);
  }
  ArvGc* gc_ = nullptr;
};

std::string description(const std::string& nodes) {
  return R"(<?xml version="1.0" encoding="utf-8"?>
<RegisterDescription ModelName="ChunkTest" VendorName="sensor-rig" StandardNameSpace="None" SchemaMajorVersion="1"
 SchemaMinorVersion="1" SchemaSubMinorVersion="0" MajorVersion="1" MinorVersion="0" SubMinorVersion="0" ToolTip=""
 ProductGuid="00000000-0000-0000-0000-000000000000" VersionGuid="00000000-0000-0000-0000-000000000000"
 xmlns="http://www.genicam.org/GenApi/Version_1_1">
  <Port Name="Device"/>
)" + nodes + "</RegisterDescription>\n";
}

// The fake GigE camera's own XML: the ids and registers its GVSP reshaper writes by.
TEST_F(ChunkResolve, TheFakeCamerasChunkFeaturesAreItsReshapersChunks) {
  parse(mock::chaos_chunk_genicam_xml(mock::fake_camera_genicam_xml()));
  const auto ts = resolve_chunk_field(gc_, "ChunkTimestamp");
  ASSERT_TRUE(ts.field) << ts.why_not;
  EXPECT_EQ(*ts.field, (ChunkField{.chunk_id = mock::kChaosChunkIdTimestamp, .offset = 0, .length = 8, .big_endian = true,
                                   .is_float = false, .is_signed = false}));
  const auto ex = resolve_chunk_field(gc_, "ChunkExposureTime");
  ASSERT_TRUE(ex.field) << ex.why_not;
  EXPECT_EQ(*ex.field, (ChunkField{.chunk_id = mock::kChaosChunkIdExposure, .offset = 0, .length = 8, .big_endian = true,
                                   .is_float = true, .is_signed = false}));
}

// As many cameras have it: an Integer and a Float whose pValue is the chunk register, little
// endian (GenICam's default), a signed 4-byte field at an offset, a 4-byte FloatReg. Resolved,
// then read from a part holding other chunks too.
TEST_F(ChunkResolve, FeaturesBehindPValueAtAnOffsetInLittleEndian) {
  parse(description(R"(
  <Integer Name="ChunkTimestamp"><pValue>ChunkTimestampReg</pValue></Integer>
  <IntReg Name="ChunkTimestampReg"><Address>0x4</Address><Length>4</Length><AccessMode>RO</AccessMode>
    <pPort>TimestampPort</pPort><Sign>Signed</Sign><Endianess>LittleEndian</Endianess></IntReg>
  <Port Name="TimestampPort"><ChunkID>1234ABCD</ChunkID></Port>
  <Float Name="ChunkExposureTime"><pValue>ChunkExposureReg</pValue></Float>
  <FloatReg Name="ChunkExposureReg"><Address>0</Address><Length>4</Length><AccessMode>RO</AccessMode>
    <pPort>ExposurePort</pPort></FloatReg>
  <Port Name="ExposurePort"><ChunkID>0x0000BEEF</ChunkID></Port>
)"));
  const auto ts = resolve_chunk_field(gc_, "ChunkTimestamp");
  ASSERT_TRUE(ts.field) << ts.why_not;
  EXPECT_EQ(*ts.field, (ChunkField{.chunk_id = 0x1234ABCD, .offset = 4, .length = 4, .big_endian = false, .is_float = false,
                                   .is_signed = true}));
  const auto ex = resolve_chunk_field(gc_, "ChunkExposureTime");
  ASSERT_TRUE(ex.field) << ex.why_not;
  EXPECT_EQ(*ex.field, (ChunkField{.chunk_id = 0xBEEF, .offset = 0, .length = 4, .big_endian = false, .is_float = true,
                                   .is_signed = false}));

  const std::uint32_t exposure_bits = std::bit_cast<std::uint32_t>(812.5f);
  Part p;
  p.add(0x55, {9, 9, 9});
  p.add(0x1234ABCD, {0, 0, 0, 0, 0xfe, 0xff, 0xff, 0xff});  // -2, little endian, after 4 other bytes
  p.add(0xBEEF, {static_cast<std::uint8_t>(exposure_bits), static_cast<std::uint8_t>(exposure_bits >> 8),
                 static_cast<std::uint8_t>(exposure_bits >> 16), static_cast<std::uint8_t>(exposure_bits >> 24)});
  const auto tc = find_chunk(p.bytes.data(), p.bytes.size(), ts.field->chunk_id);
  const auto ec = find_chunk(p.bytes.data(), p.bytes.size(), ex.field->chunk_id);
  ASSERT_TRUE(tc && ec);
  EXPECT_EQ(read_integer(*tc, *ts.field), -2);
  EXPECT_EQ(read_float(*ec, *ex.field), 812.5);
}

// What cannot be read as a plain chunk register says why, and is not guessed at.
TEST_F(ChunkResolve, WhatIsNotAChunkRegisterSaysWhy) {
  parse(description(R"(
  <IntReg Name="ChunkTimestamp"><Address>0</Address><Length>8</Length><AccessMode>RO</AccessMode><pPort>Device</pPort></IntReg>
  <Converter Name="ChunkExposureTime"><pVariable Name="R">RawReg</pVariable><FormulaTo>FROM</FormulaTo><FormulaFrom>R * 10</FormulaFrom>
    <pValue>RawReg</pValue></Converter>
  <IntReg Name="RawReg"><Address>0</Address><Length>4</Length><AccessMode>RO</AccessMode><pPort>RawPort</pPort></IntReg>
  <Port Name="RawPort"><ChunkID>77</ChunkID></Port>
  <IntReg Name="WideReg"><Address>0</Address><Length>16</Length><AccessMode>RO</AccessMode><pPort>WidePort</pPort></IntReg>
  <Port Name="WidePort"><ChunkID>78</ChunkID></Port>
  <IntReg Name="BadIdReg"><Address>0</Address><Length>4</Length><AccessMode>RO</AccessMode><pPort>BadIdPort</pPort></IntReg>
  <Port Name="BadIdPort"><ChunkID>12G4</ChunkID></Port>
)"));
  const auto device_port = resolve_chunk_field(gc_, "ChunkTimestamp");
  EXPECT_FALSE(device_port.field);
  EXPECT_NE(device_port.why_not.find("no ChunkID"), std::string::npos) << device_port.why_not;
  const auto converted = resolve_chunk_field(gc_, "ChunkExposureTime");
  EXPECT_FALSE(converted.field) << "a converter's raw register read without its formula";
  EXPECT_NE(converted.why_not.find("not held in an IntReg or FloatReg"), std::string::npos) << converted.why_not;
  const auto missing = resolve_chunk_field(gc_, "ChunkGain");
  EXPECT_FALSE(missing.field);
  EXPECT_NE(missing.why_not.find("no such feature"), std::string::npos) << missing.why_not;
  const auto wide = resolve_chunk_field(gc_, "WideReg");
  EXPECT_FALSE(wide.field);
  EXPECT_NE(wide.why_not.find("16 bytes"), std::string::npos) << wide.why_not;
  const auto bad_id = resolve_chunk_field(gc_, "BadIdReg");
  EXPECT_FALSE(bad_id.field);
  EXPECT_NE(bad_id.why_not.find("not a 32-bit hex number"), std::string::npos) << bad_id.why_not;
  EXPECT_FALSE(resolve_chunk_field(nullptr, "ChunkTimestamp").field);
}

}  // namespace
}  // namespace sensor_rig::camera::detail
