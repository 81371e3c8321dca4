// The synthetic model factory: every SPEC §7 model renders, with the model's packet rate and size;
// what no sensor of the model can do is refused with a message naming it.
#include <gtest/gtest.h>

#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "sensor_rig/lidar/mock/synthetic_ouster.hpp"

namespace sensor_rig::lidar::mock {
namespace {

struct Expect {
  const char* model;
  double pps;          // data packets per second at 600 rpm, single return
  std::size_t bytes;   // packet size
};

TEST(SyntheticFactory, EverySpecModelRenders) {
  EXPECT_EQ(synthetic_model_names(), "VLP-16, VLP-32C, HDL-32E, OS-LEGACY, OS, Pandar40P, PandarXT32");
  const Expect all[] = {{"VLP-16", 753.5, 1206},      {"VLP-32C", 1507.0, 1206},    {"HDL-32E", 1808.4, 1206},
                        {"OS-LEGACY", 640.0, 6464},   {"OS", 640.0, 32 + 16 * (12 + 32 * 12) + 32},
                        {"Pandar40P", 1799.9, 1262},  {"PandarXT32", 2500.0, 1080}};
  for (const auto& e : all) {
    SCOPED_TRACE(e.model);
    EXPECT_TRUE(is_synthetic_model(e.model));
    SyntheticOptions o;
    o.model = e.model;
    o.start_ns = 1'000'000'000'000'000'000LL;
    auto s = make_synthetic_sensor(o, Scene::standard());
    EXPECT_NEAR(s->packets_per_second(), e.pps, 0.2);
    // The sender aligns the timeline so that the first packet is due at a chosen time.
    const Nanos due = o.start_ns + 5'000'000;
    s->set_start_ns(due - s->first_packet_offset_ns());
    SyntheticPacket p = s->next();
    EXPECT_EQ(p.time_ns, due);
    if (p.position) p = s->next();  // Velodyne: the position packet comes first
    EXPECT_EQ(p.bytes.size(), e.bytes);
    EXPECT_GE(p.time_ns, o.start_ns);
    EXPECT_EQ(synthetic_options_error(o), "");
  }
  EXPECT_FALSE(is_synthetic_model("OS-2"));
}

TEST(SyntheticFactory, OusterMetadataFollowsTheOptions) {
  SyntheticOptions o;
  o.model = "OS";
  o.rpm = 1200;
  o.ouster_beams = 64;
  o.ouster_udp_port = 7600;
  auto m = synthetic_ouster_metadata(o);
  EXPECT_EQ(m.lidar_mode, "1024x20");
  EXPECT_EQ(m.pixels_per_column, 64);
  EXPECT_EQ(m.profile, ouster::Profile::kRng19Rfl8Sig16Nir16);
  EXPECT_EQ(m.udp_port_lidar, 7600);
  EXPECT_EQ(m.udp_port_imu, 7601);
  o.ouster_profile = "RNG15_RFL8_NIR8";
  o.ouster_mode = "2048x10";
  m = synthetic_ouster_metadata(o);
  EXPECT_EQ(m.profile, ouster::Profile::kRng15Rfl8Nir8);
  EXPECT_EQ(m.columns_per_frame, 2048);

  // Given metadata is what the sensor renders (the driver decodes the same file).
  SyntheticOptions g;
  g.model = "OS";
  g.metadata_text = metadata_json(m);
  g.metadata_name = "given.json";
  EXPECT_EQ(synthetic_ouster_metadata(g).columns_per_frame, 2048);
  g.model = "OS-LEGACY";  // an eUDP profile is not the legacy model
  EXPECT_NE(synthetic_options_error(g).find("use model OS"), std::string::npos);
  g.metadata_text = "{\"lidar_mode\": 5}";
  EXPECT_NE(synthetic_options_error(g).find("given.json"), std::string::npos);
}

TEST(SyntheticFactory, RefusesWhatNoSensorCanDo) {
  const auto err = [](const char* model, double rpm, const char* profile = "") {
    SyntheticOptions o;
    o.model = model;
    o.rpm = rpm;
    o.ouster_profile = profile;
    return synthetic_options_error(o);
  };
  EXPECT_NE(err("VLP-64", 600).find("unknown synthetic model 'VLP-64'"), std::string::npos);
  EXPECT_NE(err("OS-LEGACY", 900).find("10 or 20 Hz"), std::string::npos);
  EXPECT_NE(err("Pandar40P", 300).find("600 or 1200"), std::string::npos);
  EXPECT_EQ(err("PandarXT32", 300), "");
  EXPECT_NE(err("VLP-16", 5000).find("rpm"), std::string::npos);
  EXPECT_NE(err("OS", 600, "LEGACY").find("LEGACY"), std::string::npos);
  EXPECT_NE(err("OS-LEGACY", 600, "RNG19_RFL8_SIG16_NIR16").find("OS-LEGACY renders the LEGACY profile"),
            std::string::npos);
  SyntheticOptions o;
  o.model = "Pandar40P";
  o.calibration_text = "Laser id,Elevation,Azimuth\n1,15,0\n";
  o.calibration_name = "short.csv";
  EXPECT_NE(synthetic_options_error(o).find("short.csv"), std::string::npos);
}

}  // namespace
}  // namespace sensor_rig::lidar::mock
