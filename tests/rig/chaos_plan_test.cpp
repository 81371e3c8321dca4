// `rig chaos`'s plan fitted to the mock rig's models (chaos_run.hpp make_plan): a random campaign's
// drawn parameters are ones each device's mock can inject.
#include <gtest/gtest.h>

#include <set>

#include "chaos_run.hpp"
#include "rig_config.hpp"
#include "test_data.hpp"

namespace sensor_rig::rig::chaos {
namespace {

// Every lidar.corrupt of a ten-minute plan names a field its LIDAR's packets have: a drawn
// field=udp_seq on the VLP-32C made its mock refuse the plan and left the front LIDAR dead for the
// whole campaign (seed 7 with drawn parameters).
TEST(ChaosPlan, EveryCorruptFieldIsOneItsLidarsPacketsHave) {
  const RigConfig cfg = load_rig_config((test::source_dir() / "config/mock_rig.yaml").string());
  Options o;
  o.duration_s = 600;
  o.rate_per_min = 30;
  const std::map<std::string, std::set<std::string>> has = {
      {"front", {"time", "azimuth", "column_status", "byte"}},                 // VLP-32C: no frame id, no UDP sequence
      {"left", {"time", "azimuth", "frame_id", "column_status", "byte"}},      // OS-LEGACY: no UDP sequence
      {"right", {"time", "azimuth", "column_status", "byte"}}};                // Pandar40P: neither
  std::set<std::string> fields_seen;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    o.seed = seed;
    for (const auto& e : make_plan(o, devices_of(cfg), cfg)) {
      if (e.kind != "lidar.corrupt") continue;
      const std::string field = e.text("field");
      fields_seen.insert(field);
      ASSERT_TRUE(has.contains(e.device)) << e.device;
      EXPECT_TRUE(has.at(e.device).contains(field)) << "seed " << seed << ": " << e.device << " field=" << field;
    }
  }
  EXPECT_GE(fields_seen.size(), 4u) << "the draws still vary the field";
}

}  // namespace
}  // namespace sensor_rig::rig::chaos
