// Chunk data and padded rows end to end (issue 27 items 3 and 13, issue 25 camera.chunk_data and
// camera.padded_rows): rig-fake-gige-camera sends them over the real GVSP path, AravisSource must
// give every frame, at its real row stride, with the chunk's timestamp and exposure. Ground truth:
// the fake's pattern (a ramp: byte i of frame f is (f % 256 + i) % 251, rig_fake_gige_camera.cpp)
// and its truth record (dev = the ChunkTimestamp it sent, exp = the ChunkExposureTime).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <string>
#include <vector>

#include "sensor_rig/camera/aravis_source.hpp"
#include "sensor_rig/camera/mock/fake_cameras.hpp"
#include "sensor_rig/common/loopback_address.hpp"
#include "chaos_files.hpp"
#include "gige_fake_test.hpp"
#include "next_frame.hpp"

namespace sensor_rig::camera {
namespace {

constexpr int kFrames = 30;

class GigePayload : public test::GigeFakeTest<230> {
 protected:
  struct Read {
    std::uint64_t seq = 0;
    Nanos chunk_timestamp_ns = 0, exposure_ns = 0;
    std::uint64_t exposure_seq = 0;
    std::uint32_t step = 0;
    std::size_t wrong_pixels = 0;
  };
  // kFrames frames in a row, each checked against the fake's pattern; fails at the first capture
  // that is not a frame (a dropped frame is what these faults used to cost).
  std::vector<Read> read_frames(AravisSource& src, std::uint64_t& capture_ns) {
    std::vector<Read> out;
    for (int i = 0; i < kFrames; ++i) {
      auto c = test::next_frame(src, 3000);
      EXPECT_EQ(c.status, CaptureStatus::kFrame) << "capture " << i << ": " << c.error;
      if (c.status != CaptureStatus::kFrame) break;
      const auto& m = c.frame.meta();
      Read r{m.seq, m.chunk_timestamp_ns, m.exposure_ns, m.exposure_seq, m.step, 0};
      const auto data = c.frame.data();
      const std::uint32_t row = row_step(m.format, m.width);
      EXPECT_GE(data.size(), std::size_t{m.step} * m.height);
      for (std::uint32_t y = 0; y < m.height && std::size_t{y} * m.step + row <= data.size(); ++y)
        for (std::uint32_t x = 0; x < row; ++x) {
          const auto want = static_cast<std::uint8_t>((m.seq % 256 + std::size_t{y} * row + x) % 251);
          r.wrong_pixels += data[std::size_t{y} * m.step + x] != want ? 1 : 0;
        }
      out.push_back(r);
    }
    capture_ns = src.stats().incomplete;
    return out;
  }
  std::vector<Read> read_payload(const std::vector<std::string>& faults, const char* payload, std::uint32_t pad);
  std::map<std::uint64_t, truth::UnitRecord> truth_by_id() const {
    std::map<std::uint64_t, truth::UnitRecord> units;
    for (const auto& u : truth::read(folder_.truth()).units) units[static_cast<std::uint64_t>(u.unit & 0xffff)] = u;
    return units;
  }
};

// ChunkModeActive set through `features:` (payload type 0x4001, image + chunks), the exposure
// varying per frame (camera.auto_exposure): every frame, its own exposure from its chunk (not a
// GVCP read of an earlier frame's), its ChunkTimestamp = what the fake put in the chunk.
TEST_F(GigePayload, ChunkModeThroughFeaturesGivesEveryFrameWithItsOwnExposure) {
  auto fake = start({"camera.auto_exposure@0+60"});
  auto c = cfg();
  c.features = {{"ChunkModeActive", "true"}};
  AravisSource src(c);
  src.open();
  std::uint64_t incomplete = 0;
  const auto frames = read_frames(src, incomplete);
  EXPECT_STREQ(src.stats().payload, "image+chunks");
  src.close();
  fake.stop(1000);
  EXPECT_EQ(incomplete, 0u);
  ASSERT_EQ(frames.size(), static_cast<std::size_t>(kFrames));
  const auto truth = truth_by_id();
  std::size_t exposures = 0;
  for (const auto& f : frames) {
    ASSERT_TRUE(truth.count(f.seq)) << "frame " << f.seq << " read but not in the truth";
    const auto& u = truth.at(f.seq);
    EXPECT_EQ(f.wrong_pixels, 0u) << "frame " << f.seq;
    EXPECT_EQ(f.step, 320u);
    EXPECT_EQ(f.chunk_timestamp_ns, u.dev_ns) << "frame " << f.seq;
    ASSERT_GT(u.exposure_ns, 0) << "the fake sent no exposure chunk for frame " << f.seq;
    EXPECT_EQ(f.exposure_seq, f.seq) << "the exposure of another frame";
    EXPECT_EQ(f.exposure_ns, u.exposure_ns) << "frame " << f.seq;
    exposures += f.exposure_ns != frames.front().exposure_ns ? 1 : 0;
  }
  EXPECT_GT(exposures, 0u) << "auto exposure did not vary the exposure";
}

// The fake under `faults` (each injected, none "not injected"), read as kFrames frames that all
// arrive complete with the payload `payload`, rows padded by `pad` bytes, each pixel-equal to the
// fake's ramp and in its truth record.
std::vector<GigePayload::Read> GigePayload::read_payload(const std::vector<std::string>& faults, const char* payload,
                                                         std::uint32_t pad) {
  auto fake = start(faults);
  AravisSource src(cfg());
  src.open();
  std::uint64_t incomplete = 0;
  auto frames = read_frames(src, incomplete);
  EXPECT_STREQ(src.stats().payload, payload);
  src.close();
  fake.stop(1000);
  EXPECT_EQ(incomplete, 0u);
  EXPECT_EQ(frames.size(), static_cast<std::size_t>(kFrames));
  const auto truth = truth_by_id();
  for (const auto& f : frames) {
    EXPECT_TRUE(truth.count(f.seq)) << "frame " << f.seq << " read but not in the truth";
    EXPECT_EQ(f.wrong_pixels, 0u) << "frame " << f.seq;
    EXPECT_EQ(f.step, 320u + pad) << "frame " << f.seq;
  }
  const auto log = truth::read(folder_.truth());
  EXPECT_EQ(log.faults.size(), faults.size());
  for (const auto& f : log.faults) EXPECT_EQ(f.detail.find("not injected"), std::string::npos) << f.kind << ": " << f.detail;
  return frames;
}

// camera.chunk_data with payload=chunk (0x0004: no image infos in the leader, the image its
// first chunk), rows padded too: every frame (all were dropped as "not an image"), the stride
// from the image chunk's length, the chunk values read.
TEST_F(GigePayload, ChunkDataPayloadGivesEveryFrame) {
  const auto frames = read_payload({"camera.chunk_data:payload=chunk@0+60", "camera.padded_rows:bytes=16@0+60"}, "chunk_data", 16);
  const auto truth = truth_by_id();
  for (const auto& f : frames) {
    ASSERT_TRUE(truth.count(f.seq));
    EXPECT_EQ(f.chunk_timestamp_ns, truth.at(f.seq).dev_ns);
    EXPECT_EQ(f.exposure_ns, truth.at(f.seq).exposure_ns);
  }
}

// camera.chunk_data with payload=multipart (0x000A, GigE Vision 2.1, extended-id packets): part 0
// the chunks, part 1 the 2D image with padded rows; the exposure varying per frame. Every frame,
// the image found by its part's data type and size, at the part's stride (the chunk part is not
// taken for the image), and its own ChunkTimestamp and ChunkExposureTime read from the chunk part
// at the places the fake's GenICam registers give (Aravis 0.8's chunk parser reads no chunks of a
// multipart buffer: before chunk_layout.cpp, no chunk timestamp and a GVCP read of an earlier
// frame's exposure).
TEST_F(GigePayload, MultipartPayloadGivesEveryFrameWithItsOwnChunkValues) {
  const auto frames = read_payload(
      {"camera.chunk_data:payload=multipart@0+60", "camera.padded_rows:bytes=16@0+60", "camera.auto_exposure@0+60"}, "multipart", 16);
  const auto truth = truth_by_id();
  std::size_t exposures = 0;
  for (const auto& f : frames) {
    ASSERT_TRUE(truth.count(f.seq));
    const auto& u = truth.at(f.seq);
    ASSERT_GT(u.dev_ns, 0) << "the fake sent no timestamp chunk for frame " << f.seq;
    EXPECT_EQ(f.chunk_timestamp_ns, u.dev_ns) << "frame " << f.seq;
    EXPECT_EQ(f.exposure_seq, f.seq) << "the exposure of another frame";
    EXPECT_EQ(f.exposure_ns, u.exposure_ns) << "frame " << f.seq;
    exposures += f.exposure_ns != frames.front().exposure_ns ? 1 : 0;
  }
  EXPECT_GT(exposures, 0u) << "auto exposure did not vary the exposure";
}

// camera.padded_rows: 64 bytes after each row (GVSP x_padding). The image must equal, pixel for
// pixel, the unpadded pattern the fake drew; `step` is the real stride (it was width: sheared).
TEST_F(GigePayload, PaddedRowsGiveTheUnpaddedPattern) {
  auto fake = start({"camera.padded_rows:bytes=64@0+60"});
  AravisSource src(cfg());
  src.open();
  std::uint64_t incomplete = 0;
  const auto frames = read_frames(src, incomplete);
  EXPECT_STREQ(src.stats().payload, "image");
  src.close();
  fake.stop(1000);
  EXPECT_EQ(incomplete, 0u);
  ASSERT_EQ(frames.size(), static_cast<std::size_t>(kFrames));
  for (const auto& f : frames) {
    EXPECT_EQ(f.step, 320u + 64u) << "frame " << f.seq;
    EXPECT_EQ(f.wrong_pixels, 0u) << "frame " << f.seq;
    EXPECT_EQ(f.chunk_timestamp_ns, 0) << "no chunks were sent";
  }
}

// The chunk parse's cost per frame on the capture thread: what next() spends after the buffer
// was popped (complete_mono_ns is sampled right after the pop), chunk mode off and on. Printed
// for camera/README.md; bounded loosely, so that a GenICam parse per frame (ms) fails.
double post_pop_us(const SourceConfig& c, int frames) {
  AravisSource src(c);
  src.open();
  (void)test::next_frame(src, 3000);  // the chunk parser is made at the first chunked frame
  double total_us = 0;
  int n = 0;
  for (int i = 0; i < frames; ++i) {
    auto cap = test::next_frame(src, 3000);
    const Nanos returned = monotonic_now_ns();
    if (cap.status != CaptureStatus::kFrame) continue;
    total_us += static_cast<double>(returned - cap.frame.meta().complete_mono_ns) / 1e3;
    ++n;
  }
  src.close();
  return n > 0 ? total_us / n : 1e9;
}

TEST_F(GigePayload, ChunkParseCostPerFrame) {
  auto fake = start({});
  auto off = cfg();
  off.features = {{"ChunkModeActive", "false"}};
  auto on = cfg();
  on.features = {{"ChunkModeActive", "true"}};
  const double off_us = post_pop_us(off, 60), on_us = post_pop_us(on, 60);
  fake.stop(1000);
  // Multipart: the chunk part read at the places resolved at open (chunk_layout.cpp), no parser.
  auto multipart_fake = start({"camera.chunk_data:payload=multipart@0+60"});
  const double multipart_us = post_pop_us(cfg(), 60);
  multipart_fake.stop(1000);
  std::printf("next() after the pop: chunks off %.1f us, on %.1f us, multipart %.1f us per frame (60 frames each)\n", off_us,
              on_us, multipart_us);
  EXPECT_LT(on_us, 1000.0);
  EXPECT_LT(multipart_us, 1000.0);
}

}  // namespace
}  // namespace sensor_rig::camera
