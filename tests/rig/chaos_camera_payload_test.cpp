// `rig chaos` on the GigE cameras of the mock rig alone (config/mock_rig.yaml's free-running
// cameras) under camera.chunk_data (the three payload types: image + chunks, chunk data,
// multipart) and camera.padded_rows (issue 25; issue 27 items 3 and 13): every frame the fakes made is published complete (chunk-data frames were all
// dropped as incomplete), and the frames made under these faults are stamped within 1 ms of their
// true exposure start, or no worse than the same cameras' frames without them (a chunked frame's
// own exposure starved the clock mapping: stamps drifted to 3 ms). The `stamps` invariant itself is
// not asked for: under load the mapping of fault-free GigE frames is off by up to ~1.4 ms on
// this VM (issue 27's clock items, another change), which says nothing about chunks or padding.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "sensor_rig/common/truth_record.hpp"

#include "dds_domain_lease.hpp"
#include "rig_cli.hpp"
#include "rig_process.hpp"
#include "test_data.hpp"

namespace sensor_rig {
namespace {

std::string camera(const std::string& name, const std::string& address, int height) {
  return "  - name: " + name + "\n    backend: aravis\n    device: " + address +
         "\n    pixel_format: BayerRG8\n    width: 640\n    height: " + std::to_string(height) +
         "\n    frame_rate: 10\n    mock: {kind: gige}\n";
}

TEST(ChaosCameraPayload, ChunksAndPaddedRowsHoldAccountedAndStamps) {
  if (test::rig_bin_or_empty().empty()) GTEST_SKIP() << "RIG_BIN is not set (ctest sets it)";
  test::TempDir dir;
  const std::string src = test::source_dir().string();
  const std::string config = dir.write("cameras.yaml", "rig:\n  name: cameras-only\n  dds: {domain: " + std::to_string(test::lease_dds_domain()) + ", profile: " + src +
                                                           "/config/cyclonedds/loopback.xml}\n  diagnostics_period_ms: 1000\n"
                                                           "cameras:\n" +
                                                           camera("front_narrow", "127.0.0.2", 480) +
                                                           camera("corner_front_right", "127.0.0.4", 400) +
                                                           camera("corner_rear_left", "127.0.0.5", 400));
  const std::string out = (dir.path / "campaign").string();
  const auto run = test::run_rig("chaos " + config + " --duration 20 --seed 3 --json --out " + out + " --faults '"
                                 "camera.chunk_data@2+6>front_narrow;camera.chunk_data:payload=multipart@9+6>front_narrow;"
                                 "camera.padded_rows:bytes=64@2+12>corner_front_right;"
                                 "camera.chunk_data:payload=chunk@2+12>corner_rear_left;camera.padded_rows:bytes=32@4+6>corner_rear_left'");
  ASSERT_TRUE(run.code == 0 || run.code == 1) << "exit " << run.code << "\n" << run.err;
  const auto last_nl = run.out.find_last_of('\n', run.out.size() - 2);
  const auto j = nlohmann::json::parse(run.out.substr(last_nl == std::string::npos ? 0 : last_nl + 1), nullptr, false);
  ASSERT_TRUE(j.is_object()) << run.out << "\n" << run.err;
  EXPECT_EQ(j["faults"]["camera.chunk_data"], 3);
  EXPECT_EQ(j["faults"]["camera.padded_rows"], 2);
  for (const char* name : {"front_narrow", "corner_front_right", "corner_rear_left"}) {
    const auto& t = j["topics"][std::string("/sensors/camera/") + name + "/image_raw"];
    ASSERT_TRUE(t.is_object()) << name << "\n" << run.out;
    EXPECT_GT(t["sent"].get<std::uint64_t>(), 150u) << name << ": 10 Hz for ~17 s judged";
    EXPECT_EQ(t["published_complete"], t["sent"]) << name;
    EXPECT_EQ(t["published_incomplete"], 0) << name;
    EXPECT_EQ(t["counted_lost"], 0) << name;
    EXPECT_EQ(t["unaccounted"], 0) << name;
  }
  // What chunks and padding could break: a frame lost, uncounted or counted twice. Not `stamps`
  // (below, against the fault-free frames), nor `isolation` and `recovery`: camera-wide open defects
  // of issue 27 (chaos_campaign_test's known list) that this short run's few frames per window make
  // noisy (a fresh-clone run: 36 of 38 frames, 94.7 %, on a camera no fault touched).
  for (const auto& [name, verdict] : j["invariants"].items())
    if (name != "stamps" && name != "isolation" && name != "recovery") {
      EXPECT_EQ(verdict, "held") << name << "\n" << run.err;
    }
  // Stamp error per published frame (the monitor's record against the truth), under the faults
  // and without them, from 0.5 s of the campaign on (as the judge: the warm-up's first frames are
  // stamped before the mapping locks). The faults begin at 2 s.
  std::vector<double> faulted, clear;
  std::map<std::string, std::map<std::uint64_t, std::pair<Nanos, bool>>> truth;  // camera -> frame id -> (acq, faulted)
  for (const char* name : {"front_narrow", "corner_front_right", "corner_rear_left"}) {
    const auto log = truth::read(out + "/truth/" + name + ".jsonl");
    Nanos judged_from = 0;
    for (const auto& f : log.faults) judged_from = judged_from == 0 ? f.at_ns - 1'500'000'000 : std::min(judged_from, f.at_ns - 1'500'000'000);
    for (const auto& u : log.units) {
      if (u.acq_ns < judged_from) continue;
      bool in = false;
      for (const auto& f : log.faults) in = in || (u.acq_ns >= f.at_ns && u.acq_ns <= f.until_ns);
      truth["/sensors/camera/" + std::string(name) + "/image_raw"][static_cast<std::uint64_t>(u.unit & 0xffff)] = {u.acq_ns, in};
    }
  }
  std::ifstream csv(out + "/monitor.csv");
  std::string line;
  std::getline(csv, line);  // topic,seq,acquisition_ns,...
  while (std::getline(csv, line)) {
    std::stringstream ss(line);
    std::string topic, seq, acq;
    std::getline(ss, topic, ',');
    std::getline(ss, seq, ',');
    std::getline(ss, acq, ',');
    const auto cam = truth.find(topic);
    if (cam == truth.end() || seq.empty() || acq.empty()) continue;
    const auto unit = cam->second.find(std::stoull(seq));
    if (unit == cam->second.end()) continue;
    const double error_ms = std::abs(static_cast<double>(std::stoll(acq) - unit->second.first)) / 1e6;
    (unit->second.second ? faulted : clear).push_back(error_ms);
  }
  ASSERT_GT(faulted.size(), 300u) << "frames under the faults";
  ASSERT_GT(clear.size(), 100u) << "frames without them";
  // The median, not the tails: a frame's extreme error follows the host's load (1.63 vs 1.65 ms max
  // in one suite run), while what chunks or padding would break (a frame's own exposure not
  // followed: stamps drifting from 1 to 3 ms, 5087145) moves the body.
  const auto quantile = [](std::vector<double> v, double q) {
    std::sort(v.begin(), v.end());
    return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))];
  };
  const double p50_faulted = quantile(faulted, 0.5), p50_clear = quantile(clear, 0.5);
  const double p95_faulted = quantile(faulted, 0.95), p95_clear = quantile(clear, 0.95);
  std::printf("stamp error p50 / p95 / max: %.3f / %.3f / %.3f ms under chunks/padding (%zu frames), %.3f / %.3f / %.3f ms without (%zu frames)\n",
              p50_faulted, p95_faulted, quantile(faulted, 1.0), faulted.size(), p50_clear, p95_clear, quantile(clear, 1.0), clear.size());
  // The median only, with room for the load: a fresh-clone CI run (RUN_SERIAL, the rig's own load)
  // gave p95 2.28 vs 1.35 ms and max 14.7 vs 9.5 ms, p50 1.30 vs 1.10; the defect this guards
  // against moved the median by ~1 ms (stamps drifting 1 -> 3 ms over the run).
  EXPECT_LT(p50_faulted, p50_clear + 0.5) << "chunks or padding cost the stamps";
}

// Issue 27: free-running GigE cameras without a fault were stamped 0.7-1.5 ms late (p50 ~1 ms;
// `stamps` broken). Not the clock mapping: its input was late. The three fakes (SCHED_FIFO 1, one
// frame instant: the Aravis fake exposes on CLOCK_REALTIME period boundaries) sent their ~190
// packets back to back, holding the rig's receiving threads (normal priority) off their leaders by
// 0.6-2 ms every frame, and a fake held off its core sent its leader up to 4 ms after the exposure
// it reported; the mapping (leader = exposure start + exposure, lower envelope) carried both as a
// bias. The fake now sends its leader alone (its receiver takes it before the data) and reports
// the exposure its leader follows.
TEST(ChaosCameraStamps, FreeRunningGigeCamerasOnOneFrameInstantAreStampedWithin1Ms) {
  if (test::rig_bin_or_empty().empty()) GTEST_SKIP() << "RIG_BIN is not set (ctest sets it)";
  test::TempDir dir;
  const std::string src = test::source_dir().string();
  const std::string config = dir.write("cameras.yaml", "rig:\n  name: cameras-only\n  dds: {domain: " + std::to_string(test::lease_dds_domain()) +
                                                           ", profile: " + src + "/config/cyclonedds/loopback.xml}\n  diagnostics_period_ms: 1000\n"
                                                           "cameras:\n" +
                                                           camera("front_narrow", "127.0.0.2", 480) +
                                                           camera("corner_front_right", "127.0.0.4", 400) +
                                                           camera("corner_rear_left", "127.0.0.5", 400));
  const std::string out = (dir.path / "campaign").string();
  const auto run = test::run_rig("chaos " + config + " --duration 10 --warmup 3 --seed 3 --json --faults none --out " + out);
  ASSERT_TRUE(run.code == 0 || run.code == 1) << "exit " << run.code << "\n" << run.err;
  const auto last_nl = run.out.find_last_of('\n', run.out.size() - 2);
  const auto j = nlohmann::json::parse(run.out.substr(last_nl == std::string::npos ? 0 : last_nl + 1), nullptr, false);
  ASSERT_TRUE(j.is_object()) << run.out << "\n" << run.err;
  EXPECT_EQ(j["invariants"]["stamps"], "held") << run.err;
  for (const char* name : {"front_narrow", "corner_front_right", "corner_rear_left"}) {
    const auto& t = j["topics"][std::string("/sensors/camera/") + name + "/image_raw"];
    ASSERT_TRUE(t.is_object()) << name << "\n" << run.out;
    EXPECT_GT(t["sent"].get<std::uint64_t>(), 50u) << name;  // 10 Hz over the judged ~7 s
    // The defect's signature was the body of the stamps (p50 ~1 ms, 0.7-1.5). Of ~70 frames the
    // p99 is the largest: one frame the loaded host held 2.4 ms (a fresh-clone suite, 2026-11-29)
    // says nothing about it; `stamps` above bounds every frame.
    EXPECT_LT(t["stamp_error_p50_ms"].get<double>(), 0.5) << name;
    std::printf("%s: stamp error p50 %.3f, p99 %.3f, max %.3f ms\n", name, t["stamp_error_p50_ms"].get<double>(),
                t["stamp_error_p99_ms"].get<double>(), t["stamp_error_max_ms"].get<double>());
    // The fake's own part: its leader leaves at the end of the exposure it reports (10 ms, the
    // Aravis fake's default), within 0.5 ms for 95 % of the frames (before: p90 0.9-1.1 ms here).
    const auto log = truth::read(out + "/truth/" + name + ".jsonl");
    std::vector<double> late_ms;
    for (const auto& part : log.parts)
      if (part.fate == truth::Fate::kSent && part.tx_ns > 0) late_ms.push_back(static_cast<double>(part.tx_ns - part.acq_ns - 10'000'000) / 1e6);
    ASSERT_GT(late_ms.size(), 50u) << name;
    std::sort(late_ms.begin(), late_ms.end());
    EXPECT_GE(late_ms.front(), 0.0) << name << ": a leader before its exposure ended";
    EXPECT_LT(late_ms[late_ms.size() * 95 / 100], 0.5) << name;
  }
}

}  // namespace
}  // namespace sensor_rig
