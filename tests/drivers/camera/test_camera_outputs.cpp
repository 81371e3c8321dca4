// image_color and image_raw/compressed end to end: a source of known Bayer frames -> the node ->
// DDS readers: the colour image is the scene's colour, the JPEG decodes back to it, both carry the
// raw image's stamp, and the counters reach /diagnostics. Every JPEG is announced on /rig/stamps
// once (issue 29), with its frame's seq and stamp and its size, as image_raw is.
#include <gtest/gtest.h>
#include <turbojpeg.h>
#include <unistd.h>

#include <cstdlib>
#include <map>
#include <vector>

#include "sensor_rig/dds/stamps_writer.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/drivers/camera/camera_driver.hpp"
#include "status_value.hpp"
#include "wait.hpp"
#include "wait_bounds.hpp"

namespace sensor_rig::drivers {
namespace {

using test::wait_for;

// Frames of a uniform colour (R 200, G 120, B 40) seen through a BGGR filter, every 20 ms.
class BayerSceneSource : public camera::FrameSource {
 public:
  BayerSceneSource(std::uint32_t w, std::uint32_t h) : w_(w), h_(h), pool_(3, static_cast<std::size_t>(w) * h) {
    for (std::size_t b = 0; b < pool_.count(); ++b) {
      auto buf = pool_.buffer(b);
      for (std::uint32_t y = 0; y < h; ++y)
        for (std::uint32_t x = 0; x < w; ++x) {
          // BGGR: (even y, even x) B, (odd, odd) R, else G.
          const bool ye = y % 2 == 0, xe = x % 2 == 0;
          buf[y * w + x] = ye && xe ? 40 : (!ye && !xe ? 200 : 120);
        }
    }
  }
  void open() override { open_ = true; }
  void close() noexcept override { open_ = false; }
  [[nodiscard]] bool is_open() const noexcept override { return open_; }
  camera::Capture next(int timeout_ms) override {
    ::usleep(static_cast<useconds_t>(std::min(timeout_ms, 20)) * 1000);
    camera::Capture c;
    const auto idx = pool_.acquire();
    if (!idx) return c;
    camera::FrameMeta m;
    m.seq = ++seq_;
    m.width = w_;
    m.height = h_;
    m.step = w_;
    m.format = camera::PixelFormat::kBayerBG8;
    m.domain = camera::TimeDomain::kMonotonic;
    const auto now = clock_pair_now();
    m.device_ns = now.monotonic_ns - 1'000'000;
    m.first_rx_ns = now.vehicle_ns;
    m.complete_ns = m.first_rx_ns;
    m.complete_mono_ns = now.monotonic_ns;
    c.status = camera::CaptureStatus::kFrame;
    c.frame = camera::Frame(m, pool_.buffer(*idx), [this, i = *idx] { pool_.release(i); });
    ++stats_.completed;
    return c;
  }
  [[nodiscard]] camera::SourceStats stats() const override { return stats_; }
  [[nodiscard]] std::string describe() const override { return "bayer scene"; }

 private:
  std::uint32_t w_, h_;
  camera::BufferPool pool_;
  bool open_ = false;
  std::uint64_t seq_ = 0;
  camera::SourceStats stats_;
};

TEST(CameraOutputs, ColourAndJpegOfAKnownBayerSceneOffTheCaptureThread) {
  dds::Participant p;
  dds::StampsWriter stamps(p);
  CameraConfig cfg;
  cfg.name = "outputs_" + std::to_string(::getpid());
  cfg.frame_id = "camera_" + cfg.name;
  cfg.source.backend = "aravis";
  cfg.source.format = camera::PixelFormat::kBayerBG8;
  cfg.source.width = 320;
  cfg.source.height = 240;
  cfg.source.frame_rate = 50;
  cfg.info = camera::uncalibrated(320, 240);
  cfg.outputs.color = true;
  cfg.outputs.color_order = camera::ColorOrder::kRgb;
  cfg.outputs.compressed = true;
  cfg.outputs.jpeg_quality = 90;
  const std::string base = "/sensors/camera/" + cfg.name;
  dds::Topic<msg::Image> raw_t(p, base + "/image_raw", cfg.qos);
  dds::Reader<msg::Image> raw(p, raw_t, cfg.qos);
  dds::Topic<msg::Image> color_t(p, base + "/image_color", cfg.qos);
  dds::Reader<msg::Image> color(p, color_t, cfg.qos);
  dds::Topic<msg::CompressedImage> jpeg_t(p, base + "/image_raw/compressed", cfg.qos);
  dds::Reader<msg::CompressedImage> jpeg(p, jpeg_t, cfg.qos);
  dds::Topic<msg::SourceStamps> stamps_t(p, dds::kStampsTopic, dds::stamps_qos());
  dds::Reader<msg::SourceStamps> stamps_reader(p, stamps_t, dds::stamps_qos());
  CameraDriver driver(cfg, std::make_unique<BayerSceneSource>(320, 240), p, stamps);
  driver.start();
  ASSERT_TRUE(color.wait_for_writers(1, test::kDiscoveryMs));
  ASSERT_TRUE(jpeg.wait_for_writers(1, test::kDiscoveryMs));
  ASSERT_TRUE(raw.wait_for_writers(1, test::kDiscoveryMs));
  ASSERT_TRUE(stamps_reader.wait_for_writers(1, test::kDiscoveryMs));

  // This camera's announcements by topic and header stamp: seq, size, publish time; a second one
  // of a sample is a failure.
  struct Announced {
    std::uint64_t seq = 0;
    std::uint32_t size = 0;
    Nanos acquisition = 0, publish = 0;
  };
  std::map<std::string, std::map<Nanos, Announced>> announced;
  const auto take_stamps = [&] {
    stamps_reader.take([&](const msg::SourceStamps& s, const dds_sample_info_t&) {
      const std::string topic = s.topic != nullptr ? s.topic : "";
      if (topic.rfind(base + "/", 0) != 0) return;
      const bool added = announced[topic].emplace(msg::from_time(s.header.stamp), Announced{s.seq, s.size_bytes, s.acquisition_ns, s.publish_ns}).second;
      EXPECT_TRUE(added) << topic << " announced twice at " << msg::from_time(s.header.stamp);
    });
  };
  struct Jpeg {
    std::uint32_t size = 0;
    Nanos publish = 0;
  };
  std::map<Nanos, Jpeg> jpeg_received;  // by header stamp

  std::map<Nanos, bool> raw_stamps;
  int colours = 0, jpegs = 0;
  ASSERT_TRUE(wait_for(
      [&] {
        raw.take([&](const msg::Image& m, const dds_sample_info_t&) { raw_stamps[msg::from_time(m.header.stamp)] = true; });
        color.take([&](const msg::Image& m, const dds_sample_info_t&) {
          ++colours;
          EXPECT_STREQ(m.encoding, "rgb8");
          EXPECT_EQ(m.step, 320u * 3);
          ASSERT_EQ(m.data._length, 320u * 240 * 3);
          for (std::size_t i = 0; i < m.data._length; i += 3) {
            ASSERT_EQ(m.data._buffer[i], 200) << "pixel " << i / 3;
            ASSERT_EQ(m.data._buffer[i + 1], 120) << "pixel " << i / 3;
            ASSERT_EQ(m.data._buffer[i + 2], 40) << "pixel " << i / 3;
          }
          EXPECT_TRUE(raw_stamps.contains(msg::from_time(m.header.stamp)) || raw_stamps.empty());
        });
        take_stamps();
        jpeg.take([&](const msg::CompressedImage& m, const dds_sample_info_t& info) {
          ++jpegs;
          jpeg_received[msg::from_time(m.header.stamp)] = {m.data._length, static_cast<Nanos>(info.source_timestamp)};
          EXPECT_STREQ(m.format, "bayer_bggr8; jpeg compressed rgb8");
          EXPECT_STREQ(m.header.frame_id, cfg.frame_id.c_str());
          tjhandle h = tjInitDecompress();
          std::vector<std::uint8_t> px(320 * 240 * 3);
          ASSERT_EQ(tjDecompress2(h, m.data._buffer, m.data._length, px.data(), 320, 0, 240, TJPF_RGB, 0), 0);
          tjDestroy(h);
          double err = 0;
          for (std::size_t i = 0; i < px.size(); i += 3)
            err += std::abs(px[i] - 200) + std::abs(px[i + 1] - 120) + std::abs(px[i + 2] - 40);
          EXPECT_LT(err / static_cast<double>(px.size()), 3.0);
        });
        return colours >= 5 && jpegs >= 5;
      },
      10000))
      << "colour " << colours << " jpeg " << jpegs;
  const auto st = driver.status();
  EXPECT_GE(std::stoull(test::status_value(st, "color_frames")), 5u);
  EXPECT_GE(std::stoull(test::status_value(st, "compressed_frames")), 5u);
  EXPECT_GT(std::stoull(test::status_value(st, "compressed_bytes")), 0u);
  EXPECT_EQ(test::status_value(st, "worker_errors"), "0");
  const auto offered = std::stoull(test::status_value(st, "worker_offered"));
  EXPECT_GE(offered, std::stoull(test::status_value(st, "worker_processed")) + std::stoull(test::status_value(st, "worker_dropped")));
  driver.stop();

  // One announcement per JPEG written (the node's own count, final once stopped), none for a frame
  // it did not compress.
  const std::string compressed = base + "/image_raw/compressed", raw_topic = base + "/image_raw";
  const auto written = std::stoull(test::status_value(driver.status(), "compressed_frames"));
  EXPECT_TRUE(wait_for(
      [&] {
        take_stamps();
        return announced[compressed].size() >= written;
      },
      test::kDiscoveryMs))
      << announced[compressed].size() << " announcements of " << written << " JPEGs";
  EXPECT_EQ(announced[compressed].size(), written);
  // Each JPEG received: announced with its frame's seq (image_raw's for that stamp), stamp, size and
  // DDS source timestamp.
  ASSERT_GE(jpeg_received.size(), 5u);
  for (const auto& [stamp, j] : jpeg_received) {
    SCOPED_TRACE(stamp);
    const auto a = announced[compressed].find(stamp);
    ASSERT_NE(a, announced[compressed].end()) << "a JPEG never announced";
    EXPECT_EQ(a->second.size, j.size);
    EXPECT_EQ(a->second.publish, j.publish);
    EXPECT_EQ(a->second.acquisition, stamp);
    const auto r = announced[raw_topic].find(stamp);
    ASSERT_NE(r, announced[raw_topic].end()) << "its image_raw frame never announced";
    EXPECT_EQ(a->second.seq, r->second.seq);
  }
}

}  // namespace
}  // namespace sensor_rig::drivers
