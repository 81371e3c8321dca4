// Calibration parsing: ROS YAML and VeloView XML (shared files and inline text), the built-in
// manual values, and malformed input -> CalibrationError naming source:line and the field.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "sensor_rig/lidar/velodyne/calibration.hpp"
#include "test_support.hpp"

namespace sensor_rig::lidar::test {
namespace {

using velodyne::Calibration;
using velodyne::CalibrationError;
using velodyne::Model;

constexpr double kDeg = std::numbers::pi / 180.0;

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const CalibrationError& e) {
    return e.what();
  }
  return "<no error>";
}

void expect_same_lasers(const Calibration& a, const Calibration& b, double tol) {
  ASSERT_EQ(a.lasers.size(), b.lasers.size());
  for (std::size_t i = 0; i < a.lasers.size(); ++i) {
    EXPECT_EQ(a.lasers[i].laser_id, static_cast<int>(i));
    EXPECT_NEAR(a.lasers[i].vert_correction, b.lasers[i].vert_correction, tol) << i;
    EXPECT_NEAR(a.lasers[i].rot_correction, b.lasers[i].rot_correction, tol) << i;
    EXPECT_NEAR(a.lasers[i].vert_offset_correction, b.lasers[i].vert_offset_correction, 1e-6) << i;
  }
}

TEST(VelodyneCalibration, SharedFilesMatchTheManualDefaults) {
  struct F {
    const char* file;
    Model model;
    double resolution;
    bool offsets;  // file carries the VLP-16 vertical offsets
  };
  int checked = 0;
  for (const F f : {F{"ros_velodyne_VLP16db.yaml", Model::kVLP16, 0.002, true},
                    F{"ros_velodyne_32db.yaml", Model::kHDL32E, 0.002, true},
                    F{"ros_velodyne_VeloView-VLP-32C.yaml", Model::kVLP32C, 0.004, true},
                    F{"nebula_VLP32.yaml", Model::kVLP32C, 0.004, true},
                    F{"VeloView_VLP-16.xml", Model::kVLP16, 0.002, false},
                    F{"VeloView_HDL-32.xml", Model::kHDL32E, 0.002, true}}) {
    const std::string path = velodyne_file(f.file);
    if (!exists(path)) continue;
    ++checked;
    const Calibration c = velodyne::validate_for_model(velodyne::parse_calibration(read_text(path), path), f.model);
    EXPECT_NEAR(c.distance_resolution_m, f.resolution, 1e-12) << f.file;
    auto ref = velodyne::default_calibration(f.model);
    if (!f.offsets) {
      for (auto& l : ref.lasers) l.vert_offset_correction = 0.0;
    }
    SCOPED_TRACE(f.file);
    expect_same_lasers(c, ref, 0.006 * kDeg);  // files round the manual's angles
  }
  if (checked == 0) GTEST_SKIP() << "no calibration files under " << data_dir();
}

constexpr const char* kYaml = R"(lasers:
- {laser_id: 1, rot_correction: 0.01, vert_correction: 0.1, dist_correction: 0.02,
   vert_offset_correction: 0.003, horiz_offset_correction: 0.004}
- {laser_id: 0, vert_correction: -0.1}
num_lasers: 2
distance_resolution: 0.004
)";

TEST(VelodyneCalibration, RosYamlFields) {
  const Calibration c = velodyne::parse_ros_yaml(kYaml, "inline.yaml");
  ASSERT_EQ(c.lasers.size(), 2U);
  EXPECT_EQ(c.distance_resolution_m, 0.004);
  EXPECT_EQ(c.lasers[0].laser_id, 1);
  EXPECT_EQ(c.lasers[0].rot_correction, 0.01);
  EXPECT_EQ(c.lasers[0].dist_correction, 0.02);
  EXPECT_EQ(c.lasers[0].vert_offset_correction, 0.003);
  EXPECT_EQ(c.lasers[0].horiz_offset_correction, 0.004);
  EXPECT_EQ(c.lasers[1].rot_correction, 0.0);
  // Two lasers do not make a VLP-16: the stated count says so first ...
  EXPECT_NE(error_of([&] { velodyne::validate_for_model(c, Model::kVLP16); }).find("num_lasers 2 does not match VLP-16"),
            std::string::npos);
  // ... and without num_lasers the list is too short.
  auto unstated = c;
  unstated.num_lasers = 0;
  unstated.distance_resolution_m = 0.0;
  EXPECT_NE(error_of([&] { velodyne::validate_for_model(unstated, Model::kVLP16); }).find("needs 16"), std::string::npos);
}

TEST(VelodyneCalibration, MalformedYamlNamesLineAndKey) {
  std::string e = error_of([] { velodyne::parse_ros_yaml("lasers:\n- {laser_id: 0, vert_correction: abc}\n", "a.yaml"); });
  EXPECT_NE(e.find("a.yaml:2:"), std::string::npos) << e;
  EXPECT_NE(e.find("lasers[0].vert_correction"), std::string::npos) << e;
  e = error_of([] { velodyne::parse_ros_yaml("lasers:\n- {laser_id: 0}\n", "b.yaml"); });
  EXPECT_NE(e.find("vert_correction: required key is missing"), std::string::npos) << e;
  e = error_of([] { velodyne::parse_ros_yaml("lasers: [\n  {laser_id: 0,\n", "c.yaml"); });
  EXPECT_NE(e.find("c.yaml:"), std::string::npos) << e;
  EXPECT_NE(e.find("YAML syntax"), std::string::npos) << e;
  e = error_of([] { velodyne::parse_ros_yaml("lasers:\n- {laser_id: 0, vert_correction: 0, colour: 3}\n", "d.yaml"); });
  EXPECT_NE(e.find("d.yaml:2:"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown key"), std::string::npos) << e;
  e = error_of([] { velodyne::parse_ros_yaml("num_lasers: 1\n", "e.yaml"); });
  EXPECT_NE(e.find("lasers: required key is missing"), std::string::npos) << e;
  e = error_of([] { velodyne::parse_ros_yaml("", "f.yaml"); });
  EXPECT_NE(e.find("empty"), std::string::npos) << e;
}

std::string xml_px(int id, const char* vert, const char* rot = "0") {
  return "\t\t<item>\n\t\t\t<px class_id=\"9\" object_id=\"_" + std::to_string(id + 1) + "\">\n\t\t\t\t<id_>" +
         std::to_string(id) + "</id_>\n\t\t\t\t<rotCorrection_>" + rot + "</rotCorrection_>\n\t\t\t\t<vertCorrection_>" +
         vert + "</vertCorrection_>\n\t\t\t\t<distCorrection_>10</distCorrection_>\n\t\t\t</px>\n\t\t</item>\n";
}
std::string xml_doc(const std::string& items) {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\" standalone=\"yes\" ?>\n<!DOCTYPE boost_serialization>\n"
         "<boost_serialization signature=\"serialization::archive\" version=\"4\">\n<DB>\n\t<distLSB_>0.4</distLSB_>\n"
         "\t<points_>\n\t\t<count>2</count>\n" +
         items + "\t</points_>\n</DB>\n</boost_serialization>\n";
}

TEST(VelodyneCalibration, VeloViewXmlUnits) {
  const Calibration c = velodyne::parse_calibration(xml_doc(xml_px(0, "-15") + xml_px(1, "1.5", "-1.4")), "x.xml");
  ASSERT_EQ(c.lasers.size(), 2U);
  EXPECT_NEAR(c.distance_resolution_m, 0.004, 1e-12);   // cm -> m
  EXPECT_NEAR(c.lasers[0].vert_correction, -15 * kDeg, 1e-12);  // degrees -> rad
  EXPECT_NEAR(c.lasers[1].rot_correction, -1.4 * kDeg, 1e-12);
  EXPECT_NEAR(c.lasers[1].dist_correction, 0.10, 1e-12);  // cm -> m
}

TEST(VelodyneCalibration, MalformedXmlNamesLine) {
  // Lines: 1-5 prolog..distLSB_, 6 <points_>, 7 <count>, 8 <item>, 9 <px>, 10 <id_>, 11 <rot..>, 12 <vert..>.
  std::string e = error_of([] { velodyne::parse_veloview_xml(xml_doc(xml_px(0, "abc")), "bad.xml"); });
  EXPECT_NE(e.find("bad.xml:12: <vertCorrection_>: expected a number, got 'abc'"), std::string::npos) << e;
  std::string broken = xml_doc(xml_px(0, "1"));
  broken.replace(broken.find("</px>"), 5, "</py>");
  e = error_of([&] { velodyne::parse_veloview_xml(broken, "b2.xml"); });
  EXPECT_NE(e.find("b2.xml:14: closing tag </py> does not match <px>"), std::string::npos) << e;
  e = error_of([] { velodyne::parse_veloview_xml(xml_doc("").substr(0, 150), "cut.xml"); });
  EXPECT_NE(e.find("cut.xml:"), std::string::npos) << e;
  e = error_of([] { velodyne::parse_veloview_xml("<DB><distLSB_>0.2</distLSB_></DB>", "none.xml"); });
  EXPECT_NE(e.find("no <px>"), std::string::npos) << e;
}

TEST(VelodyneCalibration, ValidationRejectsBadTables) {
  auto c = velodyne::default_calibration(Model::kVLP16);
  auto dup = c;
  dup.lasers[3].laser_id = 2;
  EXPECT_NE(error_of([&] { velodyne::validate_for_model(dup, Model::kVLP16); }).find("laser_id 2 appears twice"),
            std::string::npos);
  auto two_point = c;
  two_point.lasers[5].dist_correction_x = 0.01;
  EXPECT_NE(error_of([&] { velodyne::validate_for_model(two_point, Model::kVLP16); }).find("two-point"),
            std::string::npos);
  auto steep = c;
  steep.lasers[0].vert_correction = 2.0;
  EXPECT_NE(error_of([&] { velodyne::validate_for_model(steep, Model::kVLP16); }).find("beyond"), std::string::npos);
  auto res = c;
  res.distance_resolution_m = 0;  // not stated: the model's
  EXPECT_EQ(velodyne::validate_for_model(res, Model::kVLP16).distance_resolution_m, 0.002);
  for (double wrong : {0.004, 0.0021, -0.002, std::nan("")}) {
    res.distance_resolution_m = wrong;
    EXPECT_NE(error_of([&] { velodyne::validate_for_model(res, Model::kVLP16); }).find("distance_resolution"),
              std::string::npos) << wrong;
  }
  // A 64-entry VeloView table is fine for a 16-laser model: ids beyond 15 are unused.
  auto big = c;
  for (int i = 16; i < 64; ++i) big.lasers.push_back(velodyne::LaserCorrection{.laser_id = i});
  EXPECT_EQ(velodyne::validate_for_model(big, Model::kVLP16).lasers.size(), 16U);
  // The decoder constructor validates too.
  velodyne::DecoderConfig cfg;
  cfg.calibration = dup;
  EXPECT_THROW(velodyne::Decoder{cfg}, CalibrationError);
}

// A calibration of another model is an error naming the file and the mismatch, never a silent
// decode (a VLP-32C file on an HDL-32E doubles every range).
TEST(VelodyneCalibration, SharedFilesOfAnotherModelAreRejected) {
  struct F {
    const char* file;
    Model model;
    const char* error;
  };
  int checked = 0;
  for (const F f : {F{"ros_velodyne_VeloView-VLP-32C.yaml", Model::kVLP16, "num_lasers 32 does not match VLP-16"},
                    F{"ros_velodyne_VeloView-VLP-32C.yaml", Model::kHDL32E,
                      "distance_resolution 0.004 m does not match HDL-32E (0.002 m per count"},
                    F{"nebula_VLP32.yaml", Model::kHDL32E, "distance_resolution 0.004 m does not match HDL-32E"},
                    F{"ros_velodyne_32db.yaml", Model::kVLP32C, "distance_resolution 0.002 m does not match VLP-32C"},
                    F{"ros_velodyne_32db.yaml", Model::kVLP16, "num_lasers 32 does not match VLP-16"},
                    F{"ros_velodyne_VLP16db.yaml", Model::kHDL32E, "num_lasers 16 does not match HDL-32E"},
                    F{"ros_velodyne_VLP16db.yaml", Model::kVLP32C, "num_lasers 16 does not match VLP-32C"},
                    F{"VeloView_HDL-32.xml", Model::kVLP16, "laser_id 16 has corrections, but VLP-16 has only 16"},
                    F{"VeloView_HDL-32.xml", Model::kVLP32C, "distance_resolution 0.002 m does not match VLP-32C"},
                    F{"VeloView_VLP-16.xml", Model::kHDL32E, "16-laser (VLP-16) calibration, not for HDL-32E"},
                    F{"VeloView_VLP-16.xml", Model::kVLP32C, "distance_resolution 0.002 m does not match VLP-32C"}}) {
    const std::string path = velodyne_file(f.file);
    if (!exists(path)) continue;
    ++checked;
    const std::string e =
        error_of([&] { velodyne::validate_for_model(velodyne::parse_calibration(read_text(path), path), f.model); });
    EXPECT_EQ(e.rfind(path + ": ", 0), 0U) << e;  // names the file first
    EXPECT_NE(e.find(f.error), std::string::npos) << f.file << " as " << velodyne::model_info(f.model).name << ": " << e;
  }
  if (checked == 0) GTEST_SKIP() << "no calibration files under " << data_dir();
}

std::string yaml_lasers(int n, const char* extra) {
  std::string s = "lasers:\n";
  for (int i = 0; i < n; ++i)
    // NOLINTNEXTLINE(bugprone-integer-division): the lasers' integer offsets around the middle one
    s += "- {laser_id: " + std::to_string(i) + ", vert_correction: " + std::to_string(0.01 * static_cast<double>(i - n / 2)) + "}\n";
  return s + extra;
}

TEST(VelodyneCalibration, GeneratedFilesOfAnotherModelAreRejected) {
  // 32 lasers without num_lasers: the list's length is the count.
  std::string e = error_of([] {
    velodyne::validate_for_model(velodyne::parse_ros_yaml(yaml_lasers(32, ""), "g32.yaml"), Model::kVLP16);
  });
  EXPECT_NE(e.find("g32.yaml: num_lasers 32 does not match VLP-16, which has 16 lasers"), std::string::npos) << e;
  // num_lasers 16 but the model has 32: the count check names it, not a missing id.
  e = error_of([] {
    velodyne::validate_for_model(velodyne::parse_ros_yaml(yaml_lasers(16, "num_lasers: 16\n"), "g16.yaml"),
                                 Model::kVLP32C);
  });
  EXPECT_NE(e.find("g16.yaml: num_lasers 16 does not match VLP-32C"), std::string::npos) << e;
  // Resolution: absent = the model's; any other value than the model's is an error.
  const auto vlp32 = velodyne::validate_for_model(velodyne::parse_ros_yaml(yaml_lasers(32, ""), "a.yaml"), Model::kVLP32C);
  EXPECT_EQ(vlp32.distance_resolution_m, 0.004);
  const auto hdl = velodyne::validate_for_model(velodyne::parse_ros_yaml(yaml_lasers(32, ""), "a.yaml"), Model::kHDL32E);
  EXPECT_EQ(hdl.distance_resolution_m, 0.002);
  EXPECT_NO_THROW(velodyne::validate_for_model(
      velodyne::parse_ros_yaml(yaml_lasers(32, "distance_resolution: 0.004\n"), "b.yaml"), Model::kVLP32C));
  e = error_of([] {
    velodyne::validate_for_model(
        velodyne::parse_ros_yaml(yaml_lasers(32, "distance_resolution: 0.003\n"), "c.yaml"), Model::kVLP32C);
  });
  EXPECT_NE(e.find("c.yaml: distance_resolution 0.003 m does not match VLP-32C (0.004 m per count"),
            std::string::npos) << e;
  // VeloView XML: an entry with data beyond the model's lasers (all-zero padding is fine, above).
  std::string items;
  for (int i = 0; i < 16; ++i) items += xml_px(i, std::to_string(i - 8).c_str());
  items += xml_px(20, "3.5");  // a 17th laser with data
  std::string xml = xml_doc(items);
  xml.replace(xml.find("0.4</distLSB_>"), 3, "0.2");
  e = error_of([&] { velodyne::validate_for_model(velodyne::parse_calibration(xml, "p.xml"), Model::kVLP16); });
  EXPECT_NE(e.find("p.xml: laser_id 20 has corrections, but VLP-16 has only 16 lasers"), std::string::npos) << e;
  // The same table without distLSB_: the model's resolution.
  std::string no_lsb = xml_doc(items.substr(0, items.rfind("\t\t<item>")));
  no_lsb.erase(no_lsb.find("\t<distLSB_>"), std::string("\t<distLSB_>0.4</distLSB_>\n").size());
  EXPECT_EQ(velodyne::validate_for_model(velodyne::parse_calibration(no_lsb, "q.xml"), Model::kVLP16).distance_resolution_m,
            0.002);
}

TEST(VelodyneModels, Registry) {
  EXPECT_EQ(velodyne::model_from_name("VLP-16"), Model::kVLP16);
  EXPECT_EQ(velodyne::model_from_name("VLP-32C"), Model::kVLP32C);
  EXPECT_EQ(velodyne::model_from_name("HDL-32E"), Model::kHDL32E);
  EXPECT_FALSE(velodyne::model_from_name("vlp16"));
  EXPECT_FALSE(velodyne::model_from_name("Pandar40P"));
  EXPECT_EQ(velodyne::all_models().size(), 3U);
}

}  // namespace
}  // namespace sensor_rig::lidar::test
