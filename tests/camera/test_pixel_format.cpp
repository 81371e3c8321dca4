#include <gtest/gtest.h>

#include "sensor_rig/camera/pixel_format.hpp"

namespace sensor_rig::camera {
namespace {

TEST(PixelFormat, GenicamFourccAndRosNamesMeetInOneRow) {
  struct Case {
    const char* name;
    PixelFormat format;
    const char* ros;
    std::uint32_t bpp;
  };
  for (const auto& c : {Case{"BayerRG8", PixelFormat::kBayerRG8, "bayer_rggb8", 1}, Case{"RGGB", PixelFormat::kBayerRG8, "bayer_rggb8", 1},
                        Case{"BayerBG8", PixelFormat::kBayerBG8, "bayer_bggr8", 1}, Case{"BA81", PixelFormat::kBayerBG8, "bayer_bggr8", 1},
                        Case{"BayerGR8", PixelFormat::kBayerGR8, "bayer_grbg8", 1}, Case{"BayerGB8", PixelFormat::kBayerGB8, "bayer_gbrg8", 1},
                        Case{"Mono8", PixelFormat::kMono8, "mono8", 1}, Case{"GREY", PixelFormat::kMono8, "mono8", 1},
                        Case{"Mono16", PixelFormat::kMono16, "mono16", 2}, Case{"RGB8", PixelFormat::kRgb8, "rgb8", 3},
                        Case{"RGB3", PixelFormat::kRgb8, "rgb8", 3}, Case{"YUYV", PixelFormat::kYuv422Yuyv, "yuv422_yuy2", 2},
                        Case{"YUV422_8", PixelFormat::kYuv422Yuyv, "yuv422_yuy2", 2}, Case{"rgb8", PixelFormat::kRgb8, "rgb8", 3}}) {
    SCOPED_TRACE(c.name);
    const auto f = parse_pixel_format(c.name);
    ASSERT_TRUE(f.has_value());
    EXPECT_EQ(*f, c.format);
    EXPECT_STREQ(info(*f).ros_encoding, c.ros);
    EXPECT_EQ(bytes_per_pixel(*f), c.bpp);
    EXPECT_EQ(row_step(*f, 1920), 1920 * c.bpp);
    EXPECT_EQ(frame_bytes(*f, 1920, 1200), std::size_t{1920} * 1200 * c.bpp);
  }
  EXPECT_FALSE(parse_pixel_format("BayerXY8").has_value());
  EXPECT_FALSE(parse_pixel_format("").has_value());
}

TEST(PixelFormat, CodesRoundTrip) {
  EXPECT_EQ(fourcc('Y', 'U', 'Y', 'V'), 0x56595559u);  // V4L2_PIX_FMT_YUYV
  EXPECT_EQ(fourcc_string(fourcc('M', 'J', 'P', 'G')), "MJPG");
  EXPECT_EQ(from_v4l2(fourcc('R', 'G', 'G', 'B')), PixelFormat::kBayerRG8);
  EXPECT_EQ(from_genicam_code(0x01080009u), PixelFormat::kBayerRG8);  // ARV_PIXEL_FORMAT_BAYER_RG_8
  EXPECT_EQ(from_genicam_code(0x02100032u), PixelFormat::kYuv422Yuyv);
  for (const auto& f : pixel_formats()) {
    if (f.genicam_code != 0) {
      EXPECT_EQ(from_genicam_code(f.genicam_code), f.format);
      EXPECT_EQ((f.genicam_code >> 16) & 0xff, f.bits_per_pixel) << f.genicam;
    }
    if (f.v4l2 != 0) {
      EXPECT_EQ(from_v4l2(f.v4l2), f.format);
    }
  }
}

TEST(PixelFormat, BackendsSayWhatTheyCanDo) {
  EXPECT_TRUE(backend_supports("v4l2", PixelFormat::kYuv422Yuyv));
  EXPECT_FALSE(backend_supports("v4l2", PixelFormat::kMjpeg));  // compressed: not image_raw
  EXPECT_FALSE(backend_supports("v4l2", PixelFormat::kBayerRG16));  // no fourcc in the table
  EXPECT_TRUE(backend_supports("aravis", PixelFormat::kBayerRG16));
  EXPECT_FALSE(backend_supports("aravis", PixelFormat::kMjpeg));
  EXPECT_FALSE(backend_supports("usb", PixelFormat::kMono8));
  EXPECT_NE(pixel_format_names("aravis").find("BayerRG8"), std::string::npos);
  EXPECT_EQ(pixel_format_names("aravis").find("MJPG"), std::string::npos);
  EXPECT_NE(pixel_format_names("v4l2").find("YUYV"), std::string::npos);
}

}  // namespace
}  // namespace sensor_rig::camera
