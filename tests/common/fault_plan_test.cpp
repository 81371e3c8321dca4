// The fault vocabulary (specs, expansion, seeded campaigns, plan files) and truth records (write,
// read back, a writer killed mid-line, a mock restarted).
#include <gtest/gtest.h>

#include <fstream>
#include <random>
#include <cmath>
#include <set>

#include "sensor_rig/common/fault_plan.hpp"
#include "sensor_rig/common/truth_record.hpp"
#include "rig_process.hpp"

namespace sensor_rig {
namespace {

TEST(FaultSpec, ParsesParametersTimesAndDevice) {
  const auto s = faults::parse_spec("lidar.reorder:n=3@12.5+2~10>front");
  EXPECT_EQ(s.kind, "lidar.reorder");
  EXPECT_EQ(s.params.at("n"), "3");
  EXPECT_EQ(s.params.at("ms"), "0") << "defaults are filled in";
  EXPECT_DOUBLE_EQ(s.start_s, 12.5);
  EXPECT_DOUBLE_EQ(s.duration_s, 2.0);
  EXPECT_DOUBLE_EQ(s.every_s, 10.0);
  EXPECT_EQ(s.device, "front");
  EXPECT_DOUBLE_EQ(faults::parse_spec("lidar.restart").duration_s, 1.0) << "the kind's default duration";
  EXPECT_EQ(faults::parse_spec(faults::to_string(s)).params, s.params) << "round trip";
}

TEST(FaultSpec, BadSpecsNameWhatIsWrong) {
  auto message = [](const char* spec) {
    try {
      faults::parse_spec(spec);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message("lidar.reord").find("unknown fault kind 'lidar.reord'"), std::string::npos);
  EXPECT_NE(message("lidar.reorder:x=1").find("takes no parameter 'x'"), std::string::npos);
  EXPECT_NE(message("lidar.reorder:n").find("not NAME=VALUE"), std::string::npos);
  EXPECT_NE(message("lidar.reorder@-1").find("start '-1'"), std::string::npos);
  EXPECT_NE(message("lidar.reorder@1~0").find("period must be > 0"), std::string::npos);
  EXPECT_NE(message("lidar.reorder>").find("needs a device"), std::string::npos);
  // A choice misspelt is an error, not the default fault injected in its place.
  EXPECT_NE(message("camera.chunk_data:payload=multipat").find("payload='multipat' is not one of image,chunk,multipart"),
            std::string::npos);
  EXPECT_NE(message("camera.ptp:state=Slav").find("is not one of Initializing,"), std::string::npos);
  EXPECT_EQ(message("camera.ptp:state=slave"), "accepted");  // any case, as the mocks read it
  EXPECT_EQ(message("camera.ptp:state=cold_start"), "accepted");
  EXPECT_NE(message("v4l2.stamp_mode:mode=sof").find("mode='sof'"), std::string::npos);
  EXPECT_NE(message("lidar.corrupt:field=azimut").find("field='azimut'"), std::string::npos);
  EXPECT_EQ(message("camera.chunk_data:payload=multipart"), "accepted");
  EXPECT_EQ(message("camera.ptp:state=Slave"), "accepted");
  EXPECT_EQ(message("lidar.corrupt:field=udp_seq"), "accepted");
}

TEST(FaultPlan, ExpandsPerDeviceAndRepeats) {
  const std::vector<faults::Device> devices{{"front", faults::DeviceClass::kLidar, true},
                                            {"left", faults::DeviceClass::kLidar, true},
                                            {"cam", faults::DeviceClass::kCamera, false}};
  const std::vector<faults::FaultSpec> specs{faults::parse_spec("lidar.loss_burst@1~4"), faults::parse_spec("camera.dies@3>cam")};
  const auto ev = faults::expand(specs, devices, 10.0);
  ASSERT_EQ(ev.size(), 2u * 3u + 1u);  // 1, 5, 9 s on both LIDARs, and the camera
  EXPECT_TRUE(std::is_sorted(ev.begin(), ev.end(), [](const auto& a, const auto& b) { return a.at_s < b.at_s; }));
  std::set<std::uint64_t> ids;
  for (const auto& e : ev) ids.insert(e.id);
  EXPECT_EQ(ids.size(), ev.size()) << "ids are unique";
}

TEST(FaultPlan, RandomCampaignIsSeededAndHasEveryKind) {
  const std::vector<faults::Device> devices{{"front", faults::DeviceClass::kLidar, true}, {"cam", faults::DeviceClass::kCamera, false}};
  const std::vector<std::string> allowed{"lidar.reorder", "lidar.restart", "camera.dies", "host.kill_mock"};
  const auto a = faults::random_campaign(allowed, devices, 30, 60, 7);
  const auto b = faults::random_campaign(allowed, devices, 30, 60, 7);
  const auto c = faults::random_campaign(allowed, devices, 30, 60, 8);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(faults::to_string(faults::FaultSpec{a[i].kind, a[i].params, a[i].at_s, a[i].duration_s, 0, a[i].device}),
                                                      faults::to_string(faults::FaultSpec{b[i].kind, b[i].params, b[i].at_s, b[i].duration_s, 0, b[i].device}));
  EXPECT_NE(a.front().at_s, c.front().at_s);
  std::set<std::string> kinds;
  for (const auto& e : a) {
    kinds.insert(e.kind);
    EXPECT_GE(e.at_s, 0.0);
    EXPECT_LT(e.at_s, 60.0);
    if (e.kind == "host.kill_mock") {
      EXPECT_EQ(e.device, "front") << "only a device with its own process is killed";
    }
  }
  EXPECT_EQ(kinds.size(), allowed.size());
  EXPECT_GT(a.size(), 20u) << "~30 per minute";
}

// Every kind's ranges parse, and each draw is a spec the parser takes (a drawn value is never one the
// kind refuses), within the stated ranges; over many draws every alternative and both ends of each
// range's quarters occur, so a range written wrong (or never used) fails here.
TEST(FaultPlan, EveryKindDrawsItsParametersFromItsRanges) {
  std::mt19937_64 rng(11);
  for (const auto& k : faults::kinds()) {
    std::map<std::string, std::set<std::string>> seen;
    double shortest = 1e9, longest = -1;
    for (int i = 0; i < 400; ++i) {
      const faults::Drawn d = faults::draw(k, rng);
      std::string spec(k.name);
      for (const auto& [name, value] : d.params) {
        spec += ":" + name + "=" + value;
        seen[name].insert(value);
      }
      spec += "@1+" + std::to_string(d.duration_s);
      EXPECT_NO_THROW(faults::parse_spec(spec)) << spec;
      shortest = std::min(shortest, d.duration_s);
      longest = std::max(longest, d.duration_s);
    }
    const std::string draws(k.draws);
    if (draws.find('+') == std::string::npos) {
      EXPECT_EQ(shortest, k.default_duration_s) << k.name << ": no duration drawn, the default kept";
      EXPECT_EQ(longest, k.default_duration_s) << k.name;
    } else {
      EXPECT_LT(shortest, longest) << k.name << ": the duration is drawn";
    }
    for (const auto& [name, values] : seen) {
      const bool drawn = draws.find(name + "=") != std::string::npos;
      if (!drawn) EXPECT_EQ(values.size(), 1u) << k.name << ": " << name << " is not drawn, its default kept";
      else EXPECT_GT(values.size(), 1u) << k.name << ": " << name << " is drawn";
    }
  }
}

TEST(FaultPlan, DrawsStayInTheirRangesAndUseEveryAlternative) {
  const faults::KindInfo* delay = faults::find_kind("host.network_delay");
  ASSERT_NE(delay, nullptr);
  EXPECT_NE(std::string(delay->draws).find("ms=1..150"), std::string::npos) << delay->draws;
  std::mt19937_64 rng(3);
  int jitter_zero = 0, jitter_wide = 0, long_holds = 0, ms_low = 0, ms_high = 0;
  for (int i = 0; i < 2000; ++i) {
    const auto d = faults::draw(*delay, rng);
    const double ms = std::stod(d.params.at("ms")), jitter = std::stod(d.params.at("jitter_ms"));
    EXPECT_GE(ms, 1);
    EXPECT_LE(ms, 150);
    EXPECT_EQ(ms, std::floor(ms)) << "whole numbers when both ends are";
    EXPECT_GE(jitter, 0);
    EXPECT_LE(jitter, 40);
    EXPECT_GE(d.duration_s, 0.5);
    EXPECT_LE(d.duration_s, 30);
    jitter_zero += jitter == 0;
    jitter_wide += jitter > 30;
    long_holds += d.duration_s > 20;  // longer than the cameras' late confirmation by far (stop 51's defect)
    ms_low += ms < 38;
    ms_high += ms > 113;
  }
  EXPECT_GT(jitter_zero, 800) << "half the draws pick the alternative 0";
  EXPECT_LT(jitter_zero, 1200);
  EXPECT_GT(jitter_wide, 100);
  EXPECT_GT(long_holds, 400);
  EXPECT_GT(ms_low, 300);
  EXPECT_GT(ms_high, 300);

  const faults::KindInfo* chunk = faults::find_kind("camera.chunk_data");
  ASSERT_NE(chunk, nullptr);
  std::map<std::string, int> payloads;
  for (int i = 0; i < 300; ++i) ++payloads[faults::draw(*chunk, rng).params.at("payload")];
  EXPECT_EQ(payloads.size(), 3u) << "image, chunk and multipart";
  for (const auto& [p, n] : payloads) EXPECT_GT(n, 60) << p;
}

// A random campaign draws: the same seed gives the same parameters, faults of one kind differ, and a
// drawn duration is at most a quarter of the horizon. With draws off it is the plan of before.
TEST(FaultPlan, RandomCampaignDrawsParametersUnlessAskedForDefaults) {
  const std::vector<faults::Device> devices{{"front", faults::DeviceClass::kLidar, true}, {"cam", faults::DeviceClass::kCamera, false}};
  const std::vector<std::string> allowed{"host.network_delay", "camera.chunk_data", "lidar.loss_burst"};
  const auto a = faults::random_campaign(allowed, devices, 60, 40, 5);
  const auto b = faults::random_campaign(allowed, devices, 60, 40, 5);
  ASSERT_EQ(a.size(), b.size());
  std::map<std::string, std::set<std::map<std::string, std::string>>> params_of;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].params, b[i].params);
    EXPECT_EQ(a[i].duration_s, b[i].duration_s);
    EXPECT_LE(a[i].duration_s, 10.0) << a[i].kind << ": at most a quarter of 40 s";
    params_of[a[i].kind].insert(a[i].params);
  }
  for (const auto& [kind, sets] : params_of) EXPECT_GT(sets.size(), 1u) << kind << ": its faults differ";
  const auto fixed = faults::random_campaign(allowed, devices, 60, 40, 5, false);
  for (const auto& e : fixed) {
    const auto* k = faults::find_kind(e.kind);
    EXPECT_EQ(e.duration_s, k->default_duration_s) << e.kind;
    EXPECT_EQ(e.params, faults::parse_spec(std::string(k->name)).params) << e.kind;
  }
}

TEST(FaultPlan, FileRoundTripAndBadLines) {
  test::TempDir dir;
  faults::Plan plan;
  plan.epoch_mono_ns = 123456789;
  plan.events.push_back(faults::FaultEvent{1, "lidar.corrupt", "front", 2.5, 0, {{"field", "time"}, {"offset", "-1"}}});
  plan.events.push_back(faults::FaultEvent{2, "host.cpu_hog", "", 3, 3, {{"threads", "2"}}});
  const std::string path = (dir.path / "plan.jsonl").string();
  faults::write_plan(path, plan);
  const auto back = faults::read_plan(path);
  EXPECT_EQ(back.epoch_mono_ns, 123456789);
  ASSERT_EQ(back.events.size(), 2u);
  EXPECT_EQ(back.events[0].text("field"), "time");
  EXPECT_EQ(back.for_device("front").size(), 2u) << "its own and the host's";
  EXPECT_EQ(back.for_device("left").size(), 1u);
  const std::string bad = dir.write("bad.jsonl", "{\"fault_plan\":1}\n{\"id\":1,\"kind\":\"lidar.nope\",\"at_s\":1}\n");
  try {
    faults::read_plan(bad);
    FAIL() << "accepted an unknown kind";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.jsonl:2: unknown fault kind"), std::string::npos) << e.what();
  }
}

TEST(TruthRecord, WritesReadsAndSurvivesAKilledWriterAndARestart) {
  test::TempDir dir;
  const std::string path = (dir.path / "front.jsonl").string();
  const truth::Header h{"front", "lidar", "VLP-32C", "/sensors/lidar/front/points", "scan", "sensor"};
  {
    truth::Writer w(path, h);
    w.unit({0, 1000, 10, 2});
    w.part({0, 0, 1000, 10, 1100, truth::Fate::kSent, 0});
    w.part({1, 0, 1500, 15, 0, truth::Fate::kDropped, 4, 1});  // across the cut into unit 1
    w.fault({4, "lidar.loss_burst", 1500, 1500, 0, "packets=1 \"quoted\""});
  }
  std::ofstream(path, std::ios::app) << "{\"p\":2,\"u\":0,\"ac";  // killed mid-line, then restarted
  {
    truth::Writer w(path, h);  // the mock restarted: same unit id again
    w.unit({0, 9000, 90, 2});
  }
  std::ofstream(path, std::ios::app) << "{\"p\":3,\"u\":0,\"ac";  // killed mid-line for good
  const truth::Log log = truth::read(path);
  EXPECT_EQ(log.header.model, "VLP-32C");
  ASSERT_EQ(log.units.size(), 2u);
  EXPECT_NE(log.units[0].unit, log.units[1].unit) << "a restart's unit ids do not collide";
  EXPECT_EQ(log.restarts, 1);
  ASSERT_EQ(log.parts.size(), 2u);
  EXPECT_EQ(log.parts[1].fate, truth::Fate::kDropped);
  EXPECT_EQ(log.parts[1].fault, 4u);
  EXPECT_EQ(log.parts[1].unit_last, 1);
  EXPECT_EQ(log.parts[0].unit_last, -1);
  ASSERT_EQ(log.faults.size(), 1u);
  EXPECT_EQ(log.faults[0].detail, "packets=1 \"quoted\"");
  EXPECT_TRUE(log.cut_last_line);
  EXPECT_EQ(log.cut_lines, 2);
  // A bad line in the middle is an error naming file:line.
  const std::string bad = dir.write("bad.jsonl", "{\"truth\":1}\n{\"x\":1}\n{\"u\":1,\"acq\":2}\n");
  EXPECT_THROW(truth::read(bad), std::runtime_error);
}

}  // namespace
}  // namespace sensor_rig
