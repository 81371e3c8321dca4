// A campaign kept with `rig chaos --out` judged again (`rig chaos --judge DIR`): every part of the
// judge's input written as the campaign writes it, read back, and judged to the same verdict.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "chaos_campaign_files.hpp"
#include "chaos_check_fixture.hpp"
#include "rig_process.hpp"
#include "sensor_rig/common/fault_plan.hpp"

namespace sensor_rig::rig::chaos {
namespace {

// The files of a campaign as `rig chaos` leaves them: the truth as a mock writes it, the plan, the
// monitor's record, the fused sweeps and judge.json.
void keep(const std::filesystem::path& dir, const Input& in) {
  std::filesystem::create_directories(dir / "truth");
  for (const auto& log : in.truths) {
    truth::Writer w((dir / "truth" / (log.header.device + ".jsonl")).string(), log.header);
    for (const auto& u : log.units) w.unit(u);
    for (const auto& p : log.parts) w.part(p);
    for (const auto& f : log.faults) w.fault(f);
  }
  faults::write_plan((dir / "plan.jsonl").string(), faults::Plan{123'456'789, in.events});
  std::ofstream csv(dir / "monitor.csv");
  csv << record_csv_header() << '\n';
  for (const auto& s : in.samples) csv << to_csv_line(s) << '\n';
  csv.close();
  write_fused_sets((dir / "fused_sets.jsonl").string(), in.fused.sets);
  write_judge_input((dir / "judge.json").string(), in, {"rig up ended with status 1"});
}

// A LIDAR starved to 3 of 50 scans (isolation broken), with every field of judge.json set.
Input starved() {
  Input in = honest();
  in.samples.erase(in.samples.begin() + 3, in.samples.end());
  in.counted_lost[kTopic] = 47;
  in.unheard[kTopic] = 2;
  in.monitor[kTopic] = MonitorTotals{3, 47};
  in.expected[kTopic] = TopicExpectation{"front", 10.0, {"left", "right"}};
  in.events.push_back(faults::FaultEvent{1, "camera.dies", "corner", 0.5, 1.0, {{"ms", "300"}}});
  in.unsynchronized[kTopic] = {{kT0 + 1'000, kT0 + 2'000}, {kT0 + 5'000, kT0 + 9'000}};
  in.dbw_bridge = {{kT0 + 7, "engaged"}, {kT0 + 9, "fault (ecu timeout)"}};
  in.dbw_ecu_timeout_ns = 200'000'000;
  in.count_edge_ns = 1'500'000'000;
  in.fused.enabled = true;
  in.fused.lidar_topics = {kTopic};
  in.fused.period_ns = 100'000'000;
  in.fused.scans_dropped = 4;
  in.fused.sets = {FusedSet{1, kT0, {FusedMember{kTopic, kT0, 0}}}, FusedSet{2, kT0 + kPeriod, {FusedMember{kTopic, kT0 + kPeriod, 1}}}};
  return in;
}

TEST(ChaosCampaignFiles, AKeptCampaignReadsBackToTheInputAndItsVerdict) {
  test::TempDir dir;
  const Input in = starved();
  keep(dir.path, in);
  std::vector<std::string> errors;
  const Input back = read_campaign(dir.path, errors);
  EXPECT_EQ(errors, std::vector<std::string>{"rig up ended with status 1"});
  ASSERT_EQ(back.truths.size(), 1u);
  EXPECT_EQ(back.truths[0].units.size(), in.truths[0].units.size());
  EXPECT_EQ(back.truths[0].parts.size(), in.truths[0].parts.size());
  ASSERT_EQ(back.samples.size(), in.samples.size());
  EXPECT_EQ(back.samples[2].acquisition_ns, in.samples[2].acquisition_ns);
  ASSERT_EQ(back.events.size(), 1u);
  EXPECT_EQ(back.events[0].params.at("ms"), "300");
  EXPECT_EQ(back.epoch_vehicle_ns, in.epoch_vehicle_ns);
  EXPECT_EQ(back.window_begin_ns, in.window_begin_ns);
  EXPECT_EQ(back.window_end_ns, in.window_end_ns);
  EXPECT_EQ(back.count_edge_ns, in.count_edge_ns);
  EXPECT_EQ(back.counted_lost, in.counted_lost);
  EXPECT_EQ(back.unheard, in.unheard);
  EXPECT_EQ(back.monitor.at(kTopic).received, 3u);
  EXPECT_EQ(back.monitor.at(kTopic).lost, 47u);
  EXPECT_EQ(back.expected.at(kTopic).depends_on, (std::vector<std::string>{"left", "right"}));
  EXPECT_EQ(back.expected.at(kTopic).rate_hz, 10.0);
  EXPECT_EQ(back.unsynchronized, in.unsynchronized);
  EXPECT_EQ(back.dbw_bridge, in.dbw_bridge);
  EXPECT_EQ(back.dbw_ecu_timeout_ns, in.dbw_ecu_timeout_ns);
  EXPECT_TRUE(back.fused.enabled);
  EXPECT_EQ(back.fused.lidar_topics, in.fused.lidar_topics);
  EXPECT_EQ(back.fused.scans_dropped, 4u);
  ASSERT_EQ(back.fused.sets.size(), 2u);
  EXPECT_EQ(back.fused.sets[1].members[0].seq, 1u);
  EXPECT_EQ(back.fused.sets[1].members[0].stamp, kT0 + kPeriod);
  // The verdict, broken invariants and all, is the same.
  const Result original = check(in), again = check(back);
  EXPECT_FALSE(again.invariants.at("isolation"));
  EXPECT_EQ(result_json(again), result_json(original));
}

TEST(ChaosCampaignFiles, AFolderWithoutItsJudgeInputIsRefusedByName) {
  test::TempDir dir;
  keep(dir.path, starved());
  std::filesystem::remove(dir.path / "judge.json");
  std::vector<std::string> errors;
  try {
    (void)read_campaign(dir.path, errors);
    ADD_FAILURE() << "read a campaign without judge.json";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("judge.json: cannot read"), std::string::npos) << e.what();
  }
  // A judge.json of another format is not guessed at.
  std::ofstream(dir.path / "judge.json") << "{\"judge\": 99}\n";
  EXPECT_THROW((void)read_campaign(dir.path, errors), std::runtime_error);
  // Nor a fused sweep cut in half.
  keep(dir.path, starved());
  std::ofstream(dir.path / "fused_sets.jsonl", std::ios::app) << "{\"seq\": 3, \"stamp\"\n";
  try {
    (void)read_campaign(dir.path, errors);
    ADD_FAILURE() << "read a cut fused sweep";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("fused_sets.jsonl:3:"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace sensor_rig::rig::chaos
