// Hesai calibration: angle-correction and Firetime CSV parsing, errors with line numbers, the
// built-in tables against the vendor files, and the options path through make_decoder().
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sensor_rig/lidar/hesai/calibration.hpp"
#include "sensor_rig/lidar/hesai/packet.hpp"
#include "test_support.hpp"

namespace sensor_rig::lidar::hesai::test {
namespace {

using ::testing::HasSubstr;

std::string angle_csv(int channels, const std::string& replace_line = "", int at = 0) {
  std::string s = "\xEF\xBB\xBF" "Channel,Elevation,Azimuth\r\n";
  for (int c = 1; c <= channels; ++c) {
    const std::string line = std::to_string(c) + "," + std::to_string(15.0 - c) + ",0.05";
    s += (c + 1 == at ? replace_line : line) + "\r\n";
  }
  return s;
}

TEST(HesaiCalibration, ParsesAngleCsv) {
  const auto c = parse_angle_csv(angle_csv(32), "xt.csv", Model::kPandarXT32);
  ASSERT_EQ(c.channels.size(), 32U);
  EXPECT_DOUBLE_EQ(c.channels[0].elevation_deg, 14.0);
  EXPECT_DOUBLE_EQ(c.channels[31].elevation_deg, -17.0);
  EXPECT_DOUBLE_EQ(c.channels[5].azimuth_deg, 0.05);
  EXPECT_EQ(c.source, "xt.csv");
}

TEST(HesaiCalibration, ErrorsNameTheLine) {
  const auto err = [](const std::string& text, Model m = Model::kPandarXT32) {
    return error_of([&] { (void)parse_angle_csv(text, "cal.csv", m); });
  };
  // Line 1 is the header, channel c is on line c + 1.
  EXPECT_THAT(err(angle_csv(32, "3,1.0", 4)), HasSubstr("cal.csv:4: expected 3 fields"));
  EXPECT_THAT(err(angle_csv(32, "3,abc,0", 4)), HasSubstr("cal.csv:4: elevation 'abc' is not a number"));
  EXPECT_THAT(err(angle_csv(32, "3,1.0,0.1x", 4)), HasSubstr("cal.csv:4: azimuth '0.1x'"));
  EXPECT_THAT(err(angle_csv(32, "2,1.0,0", 4)), HasSubstr("cal.csv:4: channel 2 appears twice"));
  EXPECT_THAT(err(angle_csv(32, "33,1.0,0", 4)), HasSubstr("cal.csv:4: channel 33 is out of range 1..32"));
  EXPECT_THAT(err(angle_csv(32, "2.5,1.0,0", 4)), HasSubstr("cal.csv:4: channel '2.5' is not an integer"));
  EXPECT_THAT(err(angle_csv(32, "3,95,0", 4)), HasSubstr("cal.csv:4: elevation is beyond"));
  EXPECT_THAT(err(angle_csv(31)), HasSubstr("cal.csv: channel 32 is missing (PandarXT32 has 32 channels)"));
  EXPECT_THAT(err(angle_csv(32), Model::kPandar40P), HasSubstr("channel 33 is missing"));
  EXPECT_THAT(err(""), HasSubstr("channel 1 is missing"));
}

TEST(HesaiCalibration, FiretimeCsv) {
  std::string text = "Channel,fire time(us)\n";
  for (int c = 32; c >= 1; --c) text += std::to_string(c) + "," + std::to_string(c) + "\n";
  ASSERT_TRUE(is_firetime_csv(text));
  EXPECT_FALSE(is_firetime_csv(angle_csv(32)));
  const auto f = parse_firetime_csv(text, "fire.csv", Model::kPandarXT32);
  EXPECT_DOUBLE_EQ(f.us[0], 1.0);
  EXPECT_DOUBLE_EQ(f.us[31], 32.0);
  EXPECT_THAT(error_of([] { (void)parse_firetime_csv("Channel,fire\n1,2,3\n", "f.csv", Model::kPandarXT32); }),
              HasSubstr("f.csv:2: expected 2 fields"));
  EXPECT_THAT(error_of([] { (void)parse_firetime_csv("Channel,fire\n1,500\n", "f.csv", Model::kPandarXT32); }),
              HasSubstr("f.csv:2: fire time 500"));
}

TEST(HesaiCalibration, BuiltInFiringTimesAreTheVendorTables) {
  const struct {
    const char* file;
    Model model;
  } cases[] = {{"hesai_sdk_Pandar40P_Firetime.csv", Model::kPandar40P},
               {"hesai_sdk_PandarXT-32_Firetime.csv", Model::kPandarXT32}};
  for (const auto& c : cases) {
    const auto path = hesai_file(c.file);
    if (!exists(path)) GTEST_SKIP() << "vendor Firetime table absent: " << path;
    const auto parsed = parse_firetime_csv(read_text(path), c.file, c.model);
    const auto built_in = default_firing_times(c.model);
    ASSERT_EQ(parsed.us.size(), built_in.us.size());
    for (std::size_t i = 0; i < parsed.us.size(); ++i) EXPECT_NEAR(parsed.us[i], built_in.us[i], 1e-9) << c.file << " channel " << i + 1;
  }
}

TEST(HesaiCalibration, NominalAnglesAreCloseToTheUnitCalibrations) {
  const struct {
    const char* file;
    Model model;
  } cases[] = {{"nebula_Pandar40P.csv", Model::kPandar40P}, {"nebula_PandarXT32.csv", Model::kPandarXT32}};
  for (const auto& c : cases) {
    const auto path = hesai_file(c.file);
    if (!exists(path)) GTEST_SKIP() << "nebula calibration absent: " << path;
    const auto unit = parse_angle_csv(read_text(path), c.file, c.model);
    const auto nominal = default_calibration(c.model);
    for (std::size_t i = 0; i < unit.channels.size(); ++i) {
      EXPECT_NEAR(unit.channels[i].elevation_deg, nominal.channels[i].elevation_deg, 0.5) << c.file << " " << i + 1;
      EXPECT_NEAR(unit.channels[i].azimuth_deg, nominal.channels[i].azimuth_deg, 0.2) << c.file << " " << i + 1;
    }
    DecoderConfig cfg;
    cfg.model = c.model;
    cfg.calibration = unit;
    Decoder d(cfg);
    const int n = static_cast<int>(unit.channels.size());
    EXPECT_EQ(d.ring_of_channel(1), n - 1) << "channel 1 points highest";
    EXPECT_EQ(d.ring_of_channel(n), 0);
  }
}

TEST(HesaiCalibration, ThroughDecoderOptions) {
  DecoderOptions o;
  o.model = "PandarXT32";
  o.calibration_text = angle_csv(32, "7,x,0", 8);
  o.calibration_name = "front.csv";
  EXPECT_THAT(error_of([&] { (void)make_decoder(o); }), HasSubstr("front.csv:8: elevation 'x'"));
  o.model = "Pandar40P";
  o.calibration_text = angle_csv(32);
  EXPECT_THAT(error_of([&] { (void)make_decoder(o); }), HasSubstr("front.csv: channel 33 is missing"));
  // A Firetime CSV replaces the firing times: every channel at -10 µs.
  o.calibration_text = "Channel,fire time(us)\n";
  for (int c = 1; c <= 40; ++c) o.calibration_text += std::to_string(c) + ",-10\n";
  const auto dec = make_decoder(o);
  PacketSpec s;
  s.us = 0;
  const auto t = dec->packet_time(build_packet(s));
  ASSERT_EQ(t.kind, SensorTime::Kind::kAbsoluteNs);
  EXPECT_EQ(t.value, 1'673'398'923LL * 1'000'000'000 - 28'580 - 9 * 55'560 - 10'000);
  // The return mode is an enum from the config/CLI on: a word that is none of them never gets here.
  EXPECT_EQ(parse_return_selection("both"), std::nullopt);
  EXPECT_EQ(parse_return_selection("dual"), ReturnSelection::kDual);
}

}  // namespace
}  // namespace sensor_rig::lidar::hesai::test
