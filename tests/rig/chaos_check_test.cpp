// The judge of `rig chaos` catches each planted violation, and holds an honest rig: a LIDAR's truth
// (50 scans of 10 packets, 100 ms apart) against the samples a rig published, one lie at a time.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "chaos_check.hpp"
#include "chaos_check_fixture.hpp"

namespace sensor_rig::rig::chaos {
namespace {

TEST(ChaosCheck, AnHonestRigHoldsEveryInvariant) {
  const Result r = check(honest());
  EXPECT_TRUE(r.all_held()) << result_text(r);
  const TopicResult& t = r.topics.at(kTopic);
  EXPECT_EQ(t.sent, 50u);
  EXPECT_EQ(t.published_complete, 50u);
  EXPECT_EQ(t.unaccounted, 0u);
  EXPECT_DOUBLE_EQ(t.stamp_error_p99_ms, 0.0);
}

TEST(ChaosCheck, AScanNeitherPublishedNorCountedIsUnaccounted) {
  Input in = honest();
  in.samples.erase(in.samples.begin() + 7);
  in.monitor[kTopic] = MonitorTotals{kScans - 1, 0};
  Result r = check(in);
  EXPECT_FALSE(r.invariants.at("accounted"));
  EXPECT_EQ(r.topics.at(kTopic).unaccounted, 1u);
  EXPECT_FALSE(r.invariants.at("monitor_agrees")) << "the monitor said lost 0 for a scan that never came";
  // The same scan counted lost by the rig, and by the monitor: accounted.
  in.counted_lost[kTopic] = 1;
  in.monitor[kTopic] = MonitorTotals{kScans - 1, 1};
  r = check(in);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);
  EXPECT_TRUE(r.invariants.at("monitor_agrees")) << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).counted_lost, 1u);
}

// A mock killed (host.kill_mock) after sending scan 30's first packets and before writing its line:
// its parts are in the truth, the scan's own line is not. The rig cut that scan short and counted it
// lost: an honest count of a scan that was made, not a phantom (before, the judge knew no scan 30 and
// broke no_phantom_loss by exactly one scan per kill). Counting a scan of which not a packet was made
// is still a phantom.
TEST(ChaosCheck, AScanWhoseMockWasKilledBeforeItsLineWasMade) {
  Input in = honest();
  auto& log = in.truths[0];
  log.units.erase(log.units.begin() + 30);
  log.parts.erase(log.parts.begin() + 30 * kParts + 4, log.parts.begin() + 31 * kParts);  // 4 packets sent, then killed
  in.samples.erase(in.samples.begin() + 30);
  in.counted_lost[kTopic] = 1;
  in.monitor[kTopic] = MonitorTotals{kScans - 1, 1};
  Result r = check(in);
  EXPECT_TRUE(r.invariants.at("no_phantom_loss")) << result_text(r);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).sent, 50u);
  // Not one packet of scan 30 made: counting it lost is a phantom.
  log.parts.erase(log.parts.begin() + 30 * kParts, log.parts.begin() + 30 * kParts + 4);
  r = check(in);
  EXPECT_FALSE(r.invariants.at("no_phantom_loss")) << result_text(r);
}

// host.kill_mock mid-scan, the killed scan published: its first packet was the previous scan's last
// (across the cut), so its true first firing lies somewhere in that packet, and the rest of it was
// never made. A rig that stamps the cut inside the packet and counts the never-made packets missing
// is honest (nothing in the stream tells a kill from a loss); more than a whole scan's is a phantom.
// LIDAR campaign seed 7 (front, killed at 20.6 s): "seq 233: stamp 0.221 ms from the true
// acquisition of scan 234" and "63 packets counted missing, 0 lost or damaged" against a rig that
// was right (its stamp 100.03 ms after scan 233's, the straddling packet's first firing 0.22 ms before).
TEST(ChaosCheck, AScanCutByAKilledMockIsStampedInsideItsFirstPacketAndMayCountTheRestMissing) {
  Input in = honest();
  auto& log = in.truths[0];
  log.units.erase(log.units.begin() + 30);
  log.parts.erase(log.parts.begin() + 30 * kParts + 4, log.parts.begin() + 31 * kParts);  // 4 packets sent, then killed
  log.parts[29 * kParts + kParts - 1].unit_last = 30;  // scan 29's last packet holds scan 30's first firings
  in.samples[30].acquisition_ns = kT0 + 30 * kPeriod - 4'000'000;  // the cut, inside that packet (10 ms long)
  in.samples[30].missing_packets = 5;                               // 10 of a whole scan, 5 made
  Result r = check(in);
  EXPECT_TRUE(r.invariants.at("stamps")) << result_text(r);
  EXPECT_TRUE(r.invariants.at("no_phantom_loss")) << result_text(r);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);
  // A stamp before that packet's first firing is off; more missing than the scan lacked is a phantom.
  in.samples[30].acquisition_ns = kT0 + 30 * kPeriod - 14'000'000;
  in.samples[30].missing_packets = 6;
  r = check(in);
  EXPECT_FALSE(r.invariants.at("stamps"));
  EXPECT_FALSE(r.invariants.at("no_phantom_loss"));
  EXPECT_EQ(r.topics.at(kTopic).phantom_missing, 1u);
}

// A loss burst of 3.2 turns on a LIDAR without packet numbering (rig chaos seed 9, ten minutes: a
// VLP-32C at 900 rpm, 3.07 turns): nothing arrived for longer than the silence bound, so the rig
// cannot tell it from a silent sensor. It counts the scans at the burst's ends lost and the 2 whole
// turns inside unheard (lost or never made): accounted. Said of a shorter burst, or of more turns
// than were lost whole or made nothing, unheard is a phantom; and it covers no loss elsewhere.
TEST(ChaosCheck, TurnsUnheardCoverScansLostWholeInASilence) {
  Input in = honest();
  for (std::uint32_t p = 4; p < 3 * kParts + 6; ++p) drop_part(in, 20 + static_cast<int>(p / kParts), p % kParts);
  in.samples.erase(in.samples.begin() + 20, in.samples.begin() + 24);
  in.monitor[kTopic] = MonitorTotals{kScans - 4, 0};
  in.counted_lost[kTopic] = 2;
  Result r = check(in);
  EXPECT_FALSE(r.invariants.at("accounted")) << "2 scans neither published nor counted";
  EXPECT_FALSE(r.invariants.at("monitor_agrees"));
  in.unheard[kTopic] = 2;
  r = check(in);
  for (const char* held : {"accounted", "no_phantom_loss", "monitor_agrees"}) EXPECT_TRUE(r.invariants.at(held)) << held << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).counted_lost, 2u);
  EXPECT_EQ(r.topics.at(kTopic).counted_unheard, 2u);
  EXPECT_EQ(r.topics.at(kTopic).unaccounted, 0u);
  in.unheard[kTopic] = 3;  // one turn more than the silence held
  EXPECT_FALSE(check(in).invariants.at("no_phantom_loss"));
  // The same 2 turns unheard beside a burst of 2.6 turns: no silence, the rig heard the sensor
  // within 3 turns; its scans are lost, not unheard.
  in = honest();
  for (std::uint32_t p = 4; p < 3 * kParts; ++p) drop_part(in, 20 + static_cast<int>(p / kParts), p % kParts);
  in.samples.erase(in.samples.begin() + 20, in.samples.begin() + 23);
  in.monitor[kTopic] = MonitorTotals{kScans - 3, 0};
  in.counted_lost[kTopic] = 2;
  in.unheard[kTopic] = 1;
  r = check(in);
  EXPECT_FALSE(r.invariants.at("accounted")) << result_text(r);
  EXPECT_FALSE(r.invariants.at("no_phantom_loss")) << result_text(r);
}

// A mock killed for 5 turns (host.kill_mock): it made nothing, and the rig, which cannot tell that
// from a loss, counts them unheard. Honest up to the 5 turns; no scan was lost.
TEST(ChaosCheck, TurnsUnheardWhileTheDeviceMadeNothingAreNoPhantoms) {
  Input in = honest();
  auto& log = in.truths[0];
  log.units.erase(log.units.begin() + 30, log.units.begin() + 35);
  log.parts.erase(log.parts.begin() + 30 * kParts, log.parts.begin() + 35 * kParts);
  in.samples.erase(in.samples.begin() + 30, in.samples.begin() + 35);
  in.monitor[kTopic] = MonitorTotals{kScans - 5, 0};
  in.unheard[kTopic] = 4;
  Result r = check(in);
  for (const char* held : {"accounted", "no_phantom_loss", "monitor_agrees"}) EXPECT_TRUE(r.invariants.at(held)) << held << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).counted_unheard, 0u);
  in.unheard[kTopic] = 6;
  EXPECT_FALSE(check(in).invariants.at("no_phantom_loss"));
}

TEST(ChaosCheck, ARigThatHidesALossIsCaught) {
  Input in = honest();
  drop_part(in, 12, 3);
  drop_part(in, 12, 4);
  Result r = check(in);  // published as complete: missing 0
  EXPECT_FALSE(r.invariants.at("accounted"));
  EXPECT_EQ(r.topics.at(kTopic).hidden_missing, 2u);
  in.samples[12].missing_packets = 2;  // counted: incomplete, accounted
  r = check(in);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).published_incomplete, 1u);
  EXPECT_EQ(r.topics.at(kTopic).published_complete, 49u);
}

TEST(ChaosCheck, MissingPacketsThatArrivedArePhantoms) {
  Input in = honest();
  in.samples[20].missing_packets = 700'000;  // a corrupt time byte read as a jump of the packet counter
  Result r = check(in);
  EXPECT_FALSE(r.invariants.at("no_phantom_loss"));
  EXPECT_EQ(r.topics.at(kTopic).phantom_missing, 700'000u);
  // Counted missing for a packet that did arrive, but corrupted: not a phantom.
  in = honest();
  drop_part(in, 20, 5, truth::Fate::kCorrupted);
  in.samples[20].missing_packets = 1;
  EXPECT_TRUE(check(in).invariants.at("no_phantom_loss"));
  // A packet across the cut (its data in scans 20 and 21) lost: both scans rightly count it missing.
  in = honest();
  in.truths[0].parts[20 * kParts + kParts - 1].unit_last = 21;
  drop_part(in, 20, kParts - 1);
  in.samples[20].missing_packets = 1;
  in.samples[21].missing_packets = 1;
  Result straddle = check(in);
  EXPECT_TRUE(straddle.invariants.at("no_phantom_loss")) << result_text(straddle);
  EXPECT_TRUE(straddle.invariants.at("accounted")) << result_text(straddle);
  in.samples[21].missing_packets = 0;  // scan 21 hides it
  EXPECT_FALSE(check(in).invariants.at("accounted"));
  // More units counted lost than were not published.
  in = honest();
  in.counted_lost[kTopic] = 3;
  EXPECT_FALSE(check(in).invariants.at("no_phantom_loss"));
}

// lidar.reorder: a packet sent after its successors arrived. Counted missing while its unit's later
// packets were still to come, it is a phantom (the rig could place it); sent after every other packet
// of its unit (after the next scan's first), its scan may have gone out without it: missing is true.
TEST(ChaosCheck, AReorderedPacketIsMissingOnlyWhenItCameAfterItsScan) {
  Input in = honest();
  auto& parts = in.truths[0].parts;
  const auto delay = [&](int unit, std::uint32_t part, Nanos tx) {
    auto& p = parts[static_cast<std::size_t>(unit) * kParts + part];
    p.fate = truth::Fate::kDelayed;
    p.tx_ns = tx;
  };
  delay(20, 4, parts[20 * kParts + 6].tx_ns + 1);  // after two successors, before the scan's end
  in.samples[20].missing_packets = 1;
  Result r = check(in);
  EXPECT_FALSE(r.invariants.at("no_phantom_loss"));
  EXPECT_EQ(r.topics.at(kTopic).phantom_missing, 1u);
  delay(30, kParts - 1, parts[31 * kParts].tx_ns + 1);  // the last packet, after the next scan's first
  in.samples[30].missing_packets = 1;
  r = check(in);
  EXPECT_EQ(r.topics.at(kTopic).phantom_missing, 1u) << "scan 30's is not a phantom:\n" << result_text(r);
  in.samples[30].missing_packets = 2;  // but only that one packet
  EXPECT_EQ(check(in).topics.at(kTopic).phantom_missing, 2u);
}

TEST(ChaosCheck, AStampTwoMillisecondsOffIsCaughtAndAFirstPacketLostMovesNothing) {
  Input in = honest();
  in.samples[30].acquisition_ns += 2'000'000;
  Result r = check(in);
  EXPECT_FALSE(r.invariants.at("stamps"));
  EXPECT_NEAR(r.topics.at(kTopic).stamp_error_max_ms, 2.0, 1e-9);
  // The rig itself flagged the topic unsynchronized when it published the scan (/diagnostics
  // stamp_sync): its own warning.
  const Nanos out = in.samples[30].publish_ns;
  in.unsynchronized[kTopic] = {{out - kPeriod, out + kPeriod}};
  r = check(in);
  EXPECT_TRUE(r.invariants.at("stamps")) << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).stamps_flagged, 1u);
  in.unsynchronized.clear();
  in.samples[30].acquisition_ns -= 1'950'000;  // 50 µs: within the 0.1 ms bound
  EXPECT_TRUE(check(in).invariants.at("stamps"));
  // The scan's first two packets lost: stamping the first packet that arrived (20 ms later) is honest.
  in = honest();
  drop_part(in, 30, 0);
  drop_part(in, 30, 1);
  in.samples[30].missing_packets = 2;
  in.samples[30].acquisition_ns += 2 * kPeriod / kParts;
  r = check(in);
  EXPECT_TRUE(r.invariants.at("stamps")) << result_text(r);
  // A stamp 37 s off matches no scan at all.
  in = honest();
  in.samples[31].acquisition_ns -= 37'000'000'000;
  in.window_begin_ns -= 40'000'000'000;
  r = check(in);
  EXPECT_FALSE(r.invariants.at("stamps"));
  EXPECT_EQ(r.topics.at(kTopic).unmatched, 1u);
  EXPECT_FALSE(r.invariants.at("accounted")) << "scan 31 itself was then never published";
}

// A flag is held against when the rig published the sample, on the host's clock as its
// /diagnostics are, not against the stamp: after a host clock step back a slewed stamp lies up to
// the step after its publication, and a clock-step campaign's camera frames, published while their
// topic was flagged, were "unflagged" for stamps in the 120 ms between two flagged reports (the
// step forward that undid the step parted them by more than a report's span).
TEST(ChaosCheck, AFlagCoversTheSamplesPublishedWhileItHeldWhereverTheirStampsLie) {
  Input in = honest();
  in.samples[30].acquisition_ns += 2'000'000;  // off its truth, ~100 ms before its publication
  const Nanos out = in.samples[30].publish_ns;
  constexpr Nanos kSpan = 40'000'000;
  in.unsynchronized[kTopic] = {{out - kSpan, out + kSpan}};
  Result r = check(in);
  EXPECT_TRUE(r.invariants.at("stamps")) << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).stamps_flagged, 1u);
  // The same span around the stamp instead: the rig published it unflagged.
  const Nanos stamp = in.samples[30].acquisition_ns;
  in.unsynchronized[kTopic] = {{stamp - kSpan, stamp + kSpan}};
  r = check(in);
  EXPECT_FALSE(r.invariants.at("stamps"));
  EXPECT_EQ(r.topics.at(kTopic).stamps_flagged, 0u);
}

TEST(ChaosCheck, AScanSplitInTwoIsPublishedTwice) {
  Input in = honest();
  SampleRecord half = in.samples[40];
  half.seq = 1000;
  half.acquisition_ns += 40'000'000;  // the second half of the scan, as its own "scan"
  in.samples.push_back(half);
  const Result r = check(in);
  EXPECT_FALSE(r.invariants.at("accounted"));
  EXPECT_EQ(r.topics.at(kTopic).published_twice, 1u);
}

// A LIDAR whose stamps followed a host clock step back and are slewed out (issue 26, the LIDAR
// campaign's Ouster and Pandar40P): scans 20..44 stamped 250..10 ms before their first firing, and
// after a restart of the sensor 45..49 a whole 500 ms early. Matched by stamp they named neighbours:
// "published twice", "neither published nor counted lost", "matches no scan", and a stamp error of at
// most half a period. Each scan is its unit by its first packet's arrival (same host clock as the
// truth's sends): accounted, and the stamps judged by their real error.
TEST(ChaosCheck, ALidarScanIsItsUnitByItsPacketsArrivalNotByAStampOffByPeriods) {
  Input in = honest();
  for (int u = 0; u < kScans; ++u) {
    SampleRecord& s = in.samples[static_cast<std::size_t>(u)];
    s.first_rx_ns = in.truths[0].parts[static_cast<std::size_t>(u) * kParts].tx_ns + 60'000;
    if (u >= 20 && u < 45) s.acquisition_ns -= (45 - u) * 10'000'000;
    if (u >= 45) s.acquisition_ns -= 5 * kPeriod;
  }
  const Result r = check(in);
  const TopicResult& t = r.topics.at(kTopic);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);
  EXPECT_TRUE(r.invariants.at("monitor_agrees")) << result_text(r);
  EXPECT_EQ(t.published_twice, 0u);
  EXPECT_EQ(t.unaccounted, 0u);
  EXPECT_EQ(t.unmatched, 0u);
  EXPECT_FALSE(r.invariants.at("stamps")) << "the stamps are wrong, and said so";
  EXPECT_EQ(t.stamps_outside, 30u);
  EXPECT_NEAR(t.stamp_error_max_ms, 500.0, 1e-9);
  // Without the arrival (a record that has none) the stamp decides, as before.
  for (auto& s : in.samples) s.first_rx_ns = 0;
  EXPECT_FALSE(check(in).invariants.at("accounted"));
}

// Host time that happened twice (a clock step back): two scans' packets went out at the same host
// times, so the arrival cannot tell them apart; the stamp decides, and a stamp in doubled time is
// left out, as before.
TEST(ChaosCheck, AnArrivalTwoUnitsShareIsDecidedByTheStamp) {
  Input in = honest();
  auto& parts = in.truths[0].parts;
  for (std::uint32_t p = 0; p < kParts; ++p) parts[25 * kParts + p].tx_ns = parts[20 * kParts + p].tx_ns;  // 500 ms back
  for (int u = 0; u < kScans; ++u)
    in.samples[static_cast<std::size_t>(u)].first_rx_ns = parts[static_cast<std::size_t>(u) * kParts].tx_ns + 60'000;
  const Result r = check(in);
  EXPECT_TRUE(r.all_held()) << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).published_complete, 50u);
}

// The same shared host times, with the stamps slewed 300 ms late (a PTP LIDAR's mapped stamps after
// an earlier step back, as in the LIDAR campaign seed 7 and the whole-rig campaign): nearest the
// stamp, scan 20's sample named scan 25 too ("scan 25 published twice (seq 20 and 25)", scan 20
// unaccounted). Scans are published in order: the sample after seq 19's scan is scan 20.
TEST(ChaosCheck, AnArrivalTwoUnitsShareGoesToTheNextScanInOrderWhenTheStampsAreSlewed) {
  Input in = honest();
  auto& parts = in.truths[0].parts;
  for (std::uint32_t p = 0; p < kParts; ++p)
    for (int u = 25; u < 30; ++u) parts[static_cast<std::size_t>(u) * kParts + p].tx_ns = parts[static_cast<std::size_t>(u - 5) * kParts + p].tx_ns;
  for (int u = 0; u < kScans; ++u) {
    SampleRecord& s = in.samples[static_cast<std::size_t>(u)];
    s.first_rx_ns = parts[static_cast<std::size_t>(u) * kParts].tx_ns + 60'000;
    if (u >= 20 && u < 30) s.acquisition_ns += 300'000'000;
  }
  const Result r = check(in);
  const TopicResult& t = r.topics.at(kTopic);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);
  EXPECT_TRUE(r.invariants.at("monitor_agrees")) << result_text(r);
  EXPECT_EQ(t.published_twice, 0u);
  EXPECT_EQ(t.unaccounted, 0u);
  EXPECT_FALSE(r.invariants.at("stamps")) << "the stamps are 300 ms late, and said so";
}

// lidar.stuck_azimuth ending inside a scan: its first 6 packets were sent with a frozen azimuth and
// dropped by the rig, which stamped the scan at the first packet it kept (allowed: "what it got").
// That packet came 60 ms after the scan's first send, past half a period: matched by the stamp, the
// sample named the next scan, "published twice", as the Ouster's seq 165/166 in the LIDAR campaign
// seed 25. It is its scan by its first intact packet's arrival.
TEST(ChaosCheck, AScanWhoseFirstPacketsWereDamagedIsItsUnitByItsFirstIntactPacketsArrival) {
  Input in = honest();
  auto& parts = in.truths[0].parts;
  for (std::uint32_t p = 0; p < 6; ++p) drop_part(in, 20, p, truth::Fate::kCorrupted);
  for (int u = 0; u < kScans; ++u)
    in.samples[static_cast<std::size_t>(u)].first_rx_ns = parts[static_cast<std::size_t>(u) * kParts + (u == 20 ? 6 : 0)].tx_ns + 60'000;
  in.samples[20].acquisition_ns = parts[20 * kParts + 6].acq_ns;
  in.samples[20].dropped = 6;
  const Result r = check(in);
  const TopicResult& t = r.topics.at(kTopic);
  EXPECT_TRUE(r.all_held()) << result_text(r);
  EXPECT_EQ(t.published_twice, 0u);
  EXPECT_EQ(t.published_incomplete, 1u);
}

// The same doubled time, the scans made in it published with stamps slewed 450 ms late (a PTP LIDAR's
// after the step). Matched by arrival to scans 20-24, they are left out of the monitor's check with
// their scans; counted at their stamps they were five samples of no unit the device made while the
// monitor watched (LIDAR campaign seed 7: left "received 286 + counted 1 = 287; the device made 284").
TEST(ChaosCheck, SamplesOfScansMadeInDoubledTimeAreLeftOutOfTheMonitorsCheckWithTheirScans) {
  Input in = honest();
  in.truths[0].faults.push_back(truth::FaultRecord{1, "host.clock_step", kT0 + 25 * kPeriod, kT0 + 30 * kPeriod, -1, "ms=-500"});
  for (int u = 0; u < kScans; ++u) {
    SampleRecord& s = in.samples[static_cast<std::size_t>(u)];
    s.first_rx_ns = in.truths[0].parts[static_cast<std::size_t>(u) * kParts].tx_ns + 60'000;
    if (u >= 20 && u < 25) s.acquisition_ns += 450'000'000;
  }
  const Result r = check(in);
  EXPECT_TRUE(r.invariants.at("monitor_agrees")) << result_text(r);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).monitor_expected, 45u);
}

// Scans 25-29 sent at the host times of scans 20-24 (a -500 ms step back), `newer_after` later; the
// first packets of scans 20-24 arriving `older_arrival` after their sends, every other scan's 10 us.
Input shared_host_times(Nanos newer_after, Nanos older_arrival) {
  Input in = honest();
  auto& parts = in.truths[0].parts;
  for (std::uint32_t p = 0; p < kParts; ++p)
    for (int u = 25; u < 30; ++u)
      parts[static_cast<std::size_t>(u) * kParts + p].tx_ns = parts[static_cast<std::size_t>(u - 5) * kParts + p].tx_ns + newer_after;
  for (int u = 0; u < kScans; ++u)
    in.samples[static_cast<std::size_t>(u)].first_rx_ns =
        parts[static_cast<std::size_t>(u) * kParts].tx_ns + (u >= 20 && u < 25 ? older_arrival : 10'000);
  return in;
}

// Shared host times, the older scans' first packets arriving 2.9 ms after their sends (the host
// stalled between the truth's read of the clock and the send), the newer scans sent 0.47 ms after
// those arrivals: ChaosCampaign.AHostClockStepLeavesNoLidarStampOffUnflagged, 1 run in 5, the
// Ouster's seq 76 (first packet 2.867 ms after scan 76's send, 0.470 ms before scan 81's) named scan
// 81: "scan 81 published twice (seq 76 and 81)". An arrival comes after its send.
TEST(ChaosCheck, AnArrivalTwoUnitsShareGoesToTheScanSentBeforeIt) {
  const Result r = check(shared_host_times(3'337'000, 2'867'000));
  EXPECT_TRUE(r.all_held()) << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).published_twice, 0u);
  EXPECT_EQ(r.topics.at(kTopic).unaccounted, 0u);
}

// Shared host times again, scans 25-29 sent 1.005 ms before scans 20-24 at the same host time (just
// past the 1 ms the two reads of the clock may differ by), their samples' first packets 10 us after
// their own sends and so 995 us "before" the older scans' (LIDAR campaign seed 11, the Ouster's scans
// 176/181). Nearest the arrival, sample 25 named scan 20: "published twice", scan 25 unaccounted.
// Scans are published in order: the unit after the previous sample's goes first.
TEST(ChaosCheck, AnArrivalTwoUnitsShareGoesToTheNextScanInOrderBeyondTheReadSlack) {
  const Result r = check(shared_host_times(-1'005'000, 10'000));
  EXPECT_TRUE(r.all_held()) << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).published_twice, 0u);
  EXPECT_EQ(r.topics.at(kTopic).unaccounted, 0u);
}

// Shared host times, scans 25-29 sent 1.013 ms after scans 20-24, and the older scans' first packets
// arriving 1.71 ms after their sends: 0.70 ms after the newer scans' (the 10-minute campaign, seed
// 1, the Ouster's scans 485/490). Nearest the arrival, sample 20 named scan 25: "scan 25 published
// twice (seq 20 and 25)", five times. Both are next in order: the earlier is the sample's.
TEST(ChaosCheck, AnArrivalTwoNextUnitsShareGoesToTheEarlierInOrder) {
  Input in = shared_host_times(1'013'000, 1'710'000);
  in.truths[0].faults.push_back(truth::FaultRecord{1, "host.clock_step", kT0 + 25 * kPeriod, kT0 + 30 * kPeriod, -1, "ms=-500"});
  const Result r = check(in);
  EXPECT_TRUE(r.all_held()) << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).published_twice, 0u);
  EXPECT_EQ(r.topics.at(kTopic).unaccounted, 0u);
}

// Scan 20 (its encoder frozen) dropped by the rig and counted; every other scan's sample arriving
// 10 us after its scan's first send, scan 21's at `scan_21_first_rx` when given. Each sample must be
// its own scan's: every invariant held, none published twice, no stamp out of bounds.
void expect_each_sample_its_own_scan_around_frozen_scan_20(Input in, Nanos scan_21_first_rx = 0) {
  const auto& parts = in.truths[0].parts;
  for (int u = 0; u < kScans; ++u)
    in.samples[static_cast<std::size_t>(u)].first_rx_ns = parts[static_cast<std::size_t>(u) * kParts].tx_ns + 10'000;
  if (scan_21_first_rx != 0) in.samples[21].first_rx_ns = scan_21_first_rx;
  in.samples.erase(in.samples.begin() + 20);
  in.monitor[kTopic] = MonitorTotals{kScans - 1, 1};
  in.counted_lost[kTopic] = 1;
  const Result r = check(in);
  EXPECT_TRUE(r.all_held()) << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).published_twice, 0u);
  EXPECT_EQ(r.topics.at(kTopic).stamps_outside, 0u);
}

// A scan whose encoder froze (lidar.stuck_azimuth) sent whole, its packets damaged but its last one;
// the rig dropped it and counted it. The next scan's sample arrives 10 ms after that intact packet's
// send and 10 us after its own scan's: it is its own scan's, not the one before (taken "earlier in
// order" outside doubled time, it was stamped "a period late": 3 of 5 stuck-azimuth faults).
TEST(ChaosCheck, ASampleIsNotGivenToTheScanBeforeByThatScansLastIntactPacket) {
  Input in = honest();
  for (std::uint32_t p = 0; p + 1 < kParts; ++p) drop_part(in, 20, p, truth::Fate::kCorrupted);
  expect_each_sample_its_own_scan_around_frozen_scan_20(in);
}

// The same frozen encoder ending just before the cut: scan 20's packets damaged but its last two, the
// last of them straddling the cut (`unit_last` 21: its firings past the cut begin scan 21), sent
// 0.66 ms before scan 21's own first. Scan 21's sample begins with that packet, its receive read 5 us
// before the send was (two reads of one clock): it is scan 21's by that packet, not scan 20's by its
// first intact one 0.66 ms earlier. Before, taken as scan 20's ("sent before the arrival", then "the
// earlier in order"): "stamp 100.030 ms from the true acquisition" and the fused sweep with it
// "mixes rotations" (ten-minute campaign, seed 3, the front LIDAR at 264.2 s).
TEST(ChaosCheck, ASampleBegunByAPacketStraddlingTheCutIsTheNextScans) {
  Input in = honest();
  for (std::uint32_t p = 0; p + 2 < kParts; ++p) drop_part(in, 20, p, truth::Fate::kCorrupted);
  auto& parts = in.truths[0].parts;
  const Nanos next_first = parts[21 * kParts].tx_ns;
  for (const auto& [part, before] : {std::pair<std::uint32_t, Nanos>{kParts - 2, 1'320'000}, {kParts - 1, 660'000}}) {
    auto& pr = parts[20 * kParts + part];
    pr.tx_ns = next_first - before;
    pr.acq_ns = pr.tx_ns;
  }
  parts[20 * kParts + kParts - 1].unit_last = 21;
  expect_each_sample_its_own_scan_around_frozen_scan_20(in, parts[20 * kParts + kParts - 1].tx_ns - 5'000);
}

// A host clock step back: scans 20-24 were made in vehicle time that then happened again, so no
// sample is matched to them; two of them were not published and the rig counted both. Its count is
// held against the doubled time by number: an honest count, not a phantom (before: "the rig counted
// 2 scans lost, 0 were not published", as a frozen CAN counter across a step in the whole-rig
// campaign). Counting three is a phantom; counting none leaves two unaccounted.
TEST(ChaosCheck, LossesInTimeTheHostClockReadTwiceAreHeldByNumber) {
  Input in = honest();
  in.truths[0].faults.push_back(truth::FaultRecord{1, "host.clock_step", kT0 + 25 * kPeriod, kT0 + 30 * kPeriod, -1, "ms=-500"});
  in.samples.erase(in.samples.begin() + 21, in.samples.begin() + 23);
  in.monitor[kTopic] = MonitorTotals{kScans - 2, 0};
  in.counted_lost[kTopic] = 2;
  Result r = check(in);
  EXPECT_TRUE(r.invariants.at("no_phantom_loss")) << result_text(r);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);
  EXPECT_TRUE(r.invariants.at("monitor_agrees")) << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).sent, 45u) << "the five scans in doubled time are not judged one by one";
  EXPECT_EQ(r.topics.at(kTopic).counted_lost, 0u);
  in.counted_lost[kTopic] = 3;
  r = check(in);
  EXPECT_FALSE(r.invariants.at("no_phantom_loss")) << result_text(r);
  in.counted_lost[kTopic] = 0;
  r = check(in);
  EXPECT_TRUE(r.invariants.at("no_phantom_loss")) << result_text(r);
  EXPECT_FALSE(r.invariants.at("accounted")) << "two scans lost in doubled time, none counted";
}

// The rig's count of losses is read from once-a-second monitor lines, each behind by a diagnostics
// period: its window's edges are the units' give or take `count_edge_ns`. Scan 48, 200 ms before
// the end, not published: the count may have it or not (before, a dbw.bad_crc second across the
// end broke `accounted`, "11 frames neither published nor counted", in 1 of 2 whole-rig runs). Away
// from the edges every loss must be counted, and a count above every loss near the window is phantom.
TEST(ChaosCheck, TheCountsWindowMayMissOrTakeTheLossesNearItsEdgesOnly) {
  Input in = honest();
  in.count_edge_ns = 1'000'000'000;
  in.samples.erase(in.samples.begin() + 48);
  in.monitor[kTopic] = MonitorTotals{kScans - 1, 0};
  Result r = check(in);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);  // counted 0: the count's window ended before it
  EXPECT_TRUE(r.invariants.at("no_phantom_loss")) << result_text(r);
  in.counted_lost[kTopic] = 1;
  in.monitor[kTopic] = MonitorTotals{kScans - 1, 1};
  r = check(in);
  EXPECT_TRUE(r.all_held()) << result_text(r);
  in.counted_lost[kTopic] = 2;
  EXPECT_FALSE(check(in).invariants.at("no_phantom_loss")) << "one scan not published near the window, two counted";
  // A scan in the middle (2.5 s from both edges) not published and not counted: unaccounted.
  in = honest();
  in.count_edge_ns = 1'000'000'000;
  in.samples.erase(in.samples.begin() + 25);
  in.monitor[kTopic] = MonitorTotals{kScans - 1, 0};
  r = check(in);
  EXPECT_FALSE(r.invariants.at("accounted")) << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).unaccounted, 1u);
}

// lidar.blind_sector: a sector stops sending at run time. Its first turn's gap is the same stream of
// packets as a loss burst there (these models' packets carry no sequence), so a rig may count it
// missing; the same arc the next turn is the sensor's FOV, and counting it is a phantom.
TEST(ChaosCheck, ANewBlindArcMayBeCountedMissingOnceNotTheNextTurn) {
  Input in = honest();
  for (int u = 20; u < 25; ++u)
    for (std::uint32_t p = 3; p < 7; ++p) drop_part(in, u, p, truth::Fate::kNotSent);
  in.samples[20].missing_packets = 4;  // the first turn: no packet tells it from a loss
  Result r = check(in);
  EXPECT_TRUE(r.invariants.at("no_phantom_loss")) << result_text(r);
  EXPECT_TRUE(r.invariants.at("accounted")) << result_text(r);
  in.samples[21].missing_packets = 4;  // the second turn: the same arc again, not loss
  r = check(in);
  EXPECT_FALSE(r.invariants.at("no_phantom_loss"));
  EXPECT_EQ(r.topics.at(kTopic).phantom_missing, 4u);
  // An arc that grows (the fault began inside the sector) is new again in the turn it grows.
  in = honest();
  for (std::uint32_t p = 6; p < 7; ++p) drop_part(in, 20, p, truth::Fate::kNotSent);
  for (int u = 21; u < 25; ++u)
    for (std::uint32_t p = 2; p < 7; ++p) drop_part(in, u, p, truth::Fate::kNotSent);
  in.samples[20].missing_packets = 1;
  in.samples[21].missing_packets = 5;
  r = check(in);
  EXPECT_TRUE(r.invariants.at("no_phantom_loss")) << result_text(r);
  in.samples[20].missing_packets = 2;  // more than the turn lacked
  EXPECT_FALSE(check(in).invariants.at("no_phantom_loss"));
}

// A blind arc across the scan cut (lidar.blind_sector from_deg=201 to_deg=65): its parts lie at the
// end of one scan and the start of the next, and it is judged as one arc, held against the arc a
// turn before, not scan by scan. Here the fault begins inside the sector (scan 20 lacks its last part
// and scan 21 its first two: 3 parts), the whole arc shows first from scan 21's part 5 to scan 22's
// part 1 (7 parts), and again from scan 22 on. The rig counts each new arc where its parts lie: scan
// 22's two are the first whole arc's head, not the arc of the turn before, though scan 21 lacked 7
// parts too (judged by scan, they were phantom: the OS-LEGACY's 12 of 40). Counting scan 23's head,
// the same arc again, is a phantom.
TEST(ChaosCheck, ABlindArcAcrossTheCutIsJudgedAsOneArc) {
  Input in = honest();
  drop_part(in, 20, kParts - 1, truth::Fate::kNotSent);
  for (int u = 21; u < 26; ++u) {
    for (std::uint32_t p = 0; p < 2; ++p) drop_part(in, u, p, truth::Fate::kNotSent);
    if (u < 25)
      for (std::uint32_t p = 5; p < kParts; ++p) drop_part(in, u, p, truth::Fate::kNotSent);
  }
  in.samples[20].missing_packets = 1;
  in.samples[21].missing_packets = 7;  // the cut-short arc's 2, the first whole arc's 5
  in.samples[22].missing_packets = 2;  // the first whole arc's head
  Result r = check(in);
  EXPECT_TRUE(r.invariants.at("no_phantom_loss")) << result_text(r);
  in.samples[23].missing_packets = 2;  // the same arc a turn later
  r = check(in);
  EXPECT_FALSE(r.invariants.at("no_phantom_loss"));
  EXPECT_EQ(r.topics.at(kTopic).phantom_missing, 2u);
}

// A sector narrower than two packets (lidar.blind_sector from_deg=126 to_deg=127 on a VLP-32C) lacks
// one packet in some turns, in two turns in a row now and then. One packet missing at one place two
// turns running is no evidence of a sector (a lossy network does it), so the decoders count a gap
// of one packet missing: the judge holds them to that, and to no more. Two parts two turns running
// are an arc, and counting them the second time is a phantom.
TEST(ChaosCheck, AOnePartArcIsNewEveryTurn) {
  Input in = honest();
  for (int u = 20; u < 23; ++u) drop_part(in, u, 4, truth::Fate::kNotSent);
  for (std::size_t u = 20; u < 23; ++u) in.samples[u].missing_packets = 1;
  Result r = check(in);
  EXPECT_TRUE(r.invariants.at("no_phantom_loss")) << result_text(r);
  in.samples[21].missing_packets = 2;  // more than the turn lacked
  EXPECT_FALSE(check(in).invariants.at("no_phantom_loss"));
  in = honest();
  for (int u = 20; u < 23; ++u)
    for (std::uint32_t p = 4; p < 6; ++p) drop_part(in, u, p, truth::Fate::kNotSent);
  for (std::size_t u = 20; u < 22; ++u) in.samples[u].missing_packets = 2;
  r = check(in);
  EXPECT_FALSE(r.invariants.at("no_phantom_loss"));
  EXPECT_EQ(r.topics.at(kTopic).phantom_missing, 2u);
}

// A part not sent across the cut (its firings in two scans, `u2`) is in both, as a lost one is: the
// rig counts the first turn of a new arc there in both scans (rig chaos, the VLP-32C's new arcs from
// 245 to 30 degrees: one packet more than the judge's count in each scan).
TEST(ChaosCheck, APartNotSentAcrossTheCutIsInBothScans) {
  Input in = honest();
  in.truths[0].parts[20 * kParts + kParts - 1].unit_last = 21;
  for (std::uint32_t p = kParts - 3; p < kParts; ++p) drop_part(in, 20, p, truth::Fate::kNotSent);
  in.samples[20].missing_packets = 3;
  in.samples[21].missing_packets = 1;
  Result r = check(in);
  EXPECT_TRUE(r.invariants.at("no_phantom_loss")) << result_text(r);
  in.samples[21].missing_packets = 2;
  EXPECT_FALSE(check(in).invariants.at("no_phantom_loss"));
}

TEST(ChaosCheck, StampErrorQuantilesOfFewSamplesSeparateTheBodyFromOneLateFrame) {
  std::vector<double> errors(69, 0.06);
  errors.insert(errors.begin() + 10, 2.42);
  TopicResult t;
  set_stamp_errors(t, errors);
  EXPECT_DOUBLE_EQ(t.stamp_error_p50_ms, 0.06);
  EXPECT_DOUBLE_EQ(t.stamp_error_p99_ms, 2.42);
  EXPECT_DOUBLE_EQ(t.stamp_error_max_ms, 2.42);
  std::vector<double> none;
  TopicResult empty;
  set_stamp_errors(empty, none);
  EXPECT_DOUBLE_EQ(empty.stamp_error_p50_ms, 0.0);
}

TEST(ChaosCheck, TheJsonLineHasTheContractsKeys) {
  const auto j = nlohmann::json::parse(result_json(check(honest())));
  for (const char* k : {"faults", "topics", "invariants"}) EXPECT_TRUE(j.contains(k)) << k;
  const auto& t = j["topics"][kTopic];
  for (const char* k : {"sent", "published_complete", "published_incomplete", "counted_lost", "unaccounted", "phantom_missing",
                        "stamp_error_p50_ms", "stamp_error_p99_ms", "stamp_error_max_ms"})
    EXPECT_TRUE(t.contains(k)) << k;
  for (const char* name : kInvariants) EXPECT_EQ(j["invariants"][name], "held") << name;
}

}  // namespace
}  // namespace sensor_rig::rig::chaos
