// Ouster metadata: the shared flat files (FW 2.1.1 LEGACY, FW 2.3.0 RNG19 profile), the nested
// format, and errors that name the key at fault.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "ouster_test_support.hpp"
#include "sensor_rig/lidar/ouster/metadata.hpp"
#include "sensor_rig/lidar/ouster/scan_decoder.hpp"

namespace sensor_rig::lidar::ouster::test {
namespace {

using nlohmann::json;

std::string error_of(const std::string& text) {
  try {
    (void)parse_metadata(text, "meta.json");
  } catch (const DecoderConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(OusterMetadata, FlatLegacyOs1_32) {
  const auto path = ouster_file("OS-1-32-G_v2.1.1_1024x10.json");
  if (!exists(path)) GTEST_SKIP() << "metadata not found: " << path;
  const auto m = parse_metadata(read_text(path), path);
  EXPECT_FALSE(m.nested_format);
  EXPECT_EQ(m.prod_line, "OS-1-32-G");
  EXPECT_EQ(m.fw_rev, "v2.1.1");
  EXPECT_EQ(m.profile, Profile::kLegacy);
  EXPECT_EQ(m.header_type, HeaderType::kLegacy);
  EXPECT_EQ(m.pixels_per_column, 32);
  EXPECT_EQ(m.columns_per_packet, 16);
  EXPECT_EQ(m.columns_per_frame, 1024);
  EXPECT_EQ(m.column_window_first, 0);
  EXPECT_EQ(m.column_window_last, 1023);
  EXPECT_DOUBLE_EQ(m.frames_per_second, 10.0);
  ASSERT_EQ(m.beam_altitude_deg.size(), 32U);
  EXPECT_DOUBLE_EQ(m.beam_altitude_deg[0], 12.75);
  EXPECT_DOUBLE_EQ(m.beam_azimuth_deg[31], 4.24);
  EXPECT_DOUBLE_EQ(m.beam_to_lidar[3], 15.806);  // from lidar_origin_to_beam_origin_mm
  EXPECT_DOUBLE_EQ(m.lidar_to_sensor[0], -1.0);
  EXPECT_DOUBLE_EQ(m.lidar_to_sensor[11], 36.18);
  EXPECT_EQ(m.pixel_shift_by_row[8], 24);
  const auto l = m.layout();
  EXPECT_EQ(l.packet_size, 6464U);  // 16 x (16 + 32 x 12 + 4)
  EXPECT_NEAR(m.column_period_ns(), 97656.25, 1e-6);
}

TEST(OusterMetadata, FlatRng19Os2_128) {
  const auto path = ouster_file("OS-2-128-U1_v2.3.0_1024x10.json");
  if (!exists(path)) GTEST_SKIP() << "metadata not found: " << path;
  const auto m = parse_metadata(read_text(path), path);
  EXPECT_EQ(m.profile, Profile::kRng19Rfl8Sig16Nir16);
  EXPECT_EQ(m.header_type, HeaderType::kStandard);
  EXPECT_EQ(m.pixels_per_column, 128);
  EXPECT_EQ(m.init_id, 5431293U);
  EXPECT_DOUBLE_EQ(m.beam_to_lidar[3], 13.762);
  EXPECT_DOUBLE_EQ(m.lidar_to_sensor[11], 78.296);
  EXPECT_EQ(m.layout().packet_size, 32U + 16U * (12U + 128U * 12U) + 32U);
}

TEST(OusterMetadata, NestedFormatEveryProfile) {
  for (const auto& spec : all_profiles()) {
    const auto m = parse_metadata(nested_metadata(std::string(spec.name), 16), "nested.json");
    EXPECT_TRUE(m.nested_format);
    EXPECT_EQ(m.profile, spec.profile) << spec.name;
    EXPECT_EQ(m.init_id, 7654321U);
    EXPECT_EQ(m.prod_sn, "992200000001");
    EXPECT_EQ(m.header_type, spec.profile == Profile::kLegacy                  ? HeaderType::kLegacy
                             : spec.profile == Profile::kFusaRng15Rfl8Nir8Dual ? HeaderType::kFusa
                                                                               : HeaderType::kStandard);
    EXPECT_EQ(m.layout().pixel_size, spec.pixel_bytes);
    EXPECT_EQ(m.layout().pixel_size, pixel_bytes(spec.profile)) << "table vs manual: " << spec.name;
  }
}

TEST(OusterMetadata, NestedReturnOrderAndFps) {
  auto j = json::parse(nested_metadata("RNG19_RFL8_SIG16_NIR16_DUAL", 8, 2048, 10));
  j["config_params"]["return_order"] = "FARTHEST_TO_NEAREST";
  const auto m = parse_metadata(j.dump(), "n.json");
  EXPECT_EQ(m.return_order, ReturnOrder::kFarthestFirst);
  EXPECT_EQ(m.columns_per_frame, 2048);
  j["config_params"].erase("lidar_mode");
  j["lidar_data_format"]["fps"] = 20;
  EXPECT_DOUBLE_EQ(parse_metadata(j.dump(), "n.json").frames_per_second, 20.0);
}

TEST(OusterMetadata, ErrorsNameTheKey) {
  const auto good = json::parse(nested_metadata("RNG19_RFL8_SIG16_NIR16", 16));
  auto j = good;
  j["lidar_data_format"].erase("pixels_per_column");
  EXPECT_NE(error_of(j.dump()).find("'lidar_data_format.pixels_per_column' is missing"), std::string::npos)
      << error_of(j.dump());
  j = good;
  j["lidar_data_format"]["udp_profile_lidar"] = "RNG99";
  EXPECT_NE(error_of(j.dump()).find("lidar_data_format.udp_profile_lidar"), std::string::npos);
  EXPECT_NE(error_of(j.dump()).find("RNG99"), std::string::npos);
  j = good;
  j["beam_intrinsics"]["beam_altitude_angles"].erase(0);
  EXPECT_NE(error_of(j.dump()).find("'beam_intrinsics.beam_altitude_angles': expected 16 numbers, got 15"),
            std::string::npos)
      << error_of(j.dump());
  j = good;
  j["beam_intrinsics"]["beam_azimuth_angles"][3] = "x";
  EXPECT_NE(error_of(j.dump()).find("beam_intrinsics.beam_azimuth_angles[3]"), std::string::npos);
  j = good;
  j["lidar_intrinsics"]["lidar_to_sensor_transform"][15] = 0;
  EXPECT_NE(error_of(j.dump()).find("lidar_intrinsics.lidar_to_sensor_transform"), std::string::npos);
  j = good;
  j["config_params"]["lidar_mode"] = "2048x10";
  EXPECT_NE(error_of(j.dump()).find("config_params.lidar_mode"), std::string::npos);
  j = good;
  j["config_params"]["lidar_mode"] = "fast";
  EXPECT_NE(error_of(j.dump()).find("COLUMNSxFPS"), std::string::npos);
  j = good;
  j["lidar_data_format"]["column_window"] = json::array({0, 4096});
  EXPECT_NE(error_of(j.dump()).find("lidar_data_format.column_window[1]"), std::string::npos);
  j = good;
  j["lidar_data_format"]["pixels_per_column"] = 1024;  // 16 x (12 + 1024 x 12) > 65535
  EXPECT_NE(error_of(j.dump()).find("exceeds 65535"), std::string::npos) << error_of(j.dump());
  j = good;
  j["beam_intrinsics"].erase("beam_to_lidar_transform");
  j["beam_intrinsics"].erase("lidar_origin_to_beam_origin_mm");
  EXPECT_NE(error_of(j.dump()).find("beam_intrinsics"), std::string::npos);
  EXPECT_NE(error_of("{not json"), "");
  EXPECT_NE(error_of(R"({"lidar_mode": 1e99999})").find("not valid JSON"), std::string::npos) << "number overflow";
  EXPECT_NE(error_of("[1,2]").find("JSON object"), std::string::npos);
  EXPECT_NE(error_of("{}").find("'lidar_mode' is missing"), std::string::npos);
}

TEST(OusterMetadata, FactoryChecksModelAgainstProfile) {
  DecoderOptions o;
  o.model = "OS";
  o.metadata_name = "legacy.json";
  o.metadata_text = nested_metadata("LEGACY", 16);
  try {
    (void)make_ouster_decoder(o);
    FAIL() << "OS with a LEGACY profile must be refused";
  } catch (const DecoderConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("OS-LEGACY"), std::string::npos) << e.what();
  }
  o.model = "OS-LEGACY";
  EXPECT_NE(make_ouster_decoder(o), nullptr);
  o.metadata_text = nested_metadata("RNG19_RFL8_SIG16_NIR16", 16);
  EXPECT_THROW((void)make_ouster_decoder(o), DecoderConfigError);
  o.model = "OS";
  EXPECT_NE(make_ouster_decoder(o), nullptr);
  o.metadata_text.clear();
  EXPECT_THROW((void)make_ouster_decoder(o), DecoderConfigError);
  o.metadata_text = "{\"lidar_mode\": 3}";
  try {
    (void)make_ouster_decoder(o);
    FAIL();
  } catch (const DecoderConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("legacy.json: key 'lidar_mode'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace sensor_rig::lidar::ouster::test
