// The judge under host.network_delay: arrivals held back, by the mock or by netem on lo, against
// the planted LIDAR truth of chaos_check_fixture.hpp.
#include <gtest/gtest.h>

#include "chaos_check.hpp"
#include "chaos_check_fixture.hpp"

namespace sensor_rig::rig::chaos {
namespace {

// host.network_delay (50 ms on units 20..29): the mock holds its packets, so its truth's sends and
// the rig's arrivals are 50 ms after the firings. A sensor stamp that stays on the firing holds every
// invariant; a stamp that follows the arrival is caught (50 ms off), unless the rig flagged it; the
// fault counts once though the host and the LIDAR mock both record it.
TEST(ChaosCheck, ANetworkDelayMovesArrivalsAndAStampThatFollowsThemIsCaught) {
  constexpr Nanos kDelay = 50'000'000;
  Input in = honest();
  const auto held = [](std::int64_t unit) { return unit >= 20 && unit < 30; };
  for (auto& p : in.truths[0].parts)
    if (held(p.unit)) p.tx_ns += kDelay;
  for (auto& s : in.samples) s.first_rx_ns = s.acquisition_ns + (held(static_cast<std::int64_t>(s.seq)) ? kDelay : 0) + 100'000;
  in.events.push_back(faults::FaultEvent{5, "host.network_delay", "", 2.0, 1.0, {{"ms", "50"}}});
  const Nanos at = kT0 + 20 * kPeriod, until = kT0 + 30 * kPeriod;
  in.truths[0].faults.push_back(truth::FaultRecord{5, "host.network_delay", at, until, 20, "ms=50"});
  in.truths.push_back(truth::Log{});
  in.truths.back().header.device = "host";
  in.truths.back().faults.push_back(truth::FaultRecord{5, "host.network_delay", at, until, -1, "ms=50, via=lidar mocks"});
  Result r = check(in);
  EXPECT_TRUE(r.all_held()) << result_text(r);
  EXPECT_EQ(r.faults.at("host.network_delay"), 1u);
  EXPECT_LT(r.topics.at(kTopic).stamp_error_max_ms, 0.1);
  // A rig that stamps the arrival instead of the sensor's time.
  for (auto& s : in.samples)
    if (held(static_cast<std::int64_t>(s.seq))) s.acquisition_ns = s.first_rx_ns;
  r = check(in);
  EXPECT_FALSE(r.invariants.at("stamps"));
  EXPECT_NEAR(r.topics.at(kTopic).stamp_error_max_ms, 50.1, 1e-6);
  EXPECT_EQ(r.topics.at(kTopic).unaccounted, 0u) << "each scan still matched by its arrival: " << result_text(r);
  in.unsynchronized[kTopic] = {{at, until + kDelay + kPeriod}};
  r = check(in);
  EXPECT_TRUE(r.invariants.at("stamps")) << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).stamps_flagged, 10u);
}

// host.network_delay by netem on lo (60 ms on units 20..29): the mock's truth has the sends before the
// kernel held them, the rig's arrivals are 60 ms later. Stamps that follow the arrival (a mapped
// clock), flagged unsynchronized: each scan is still its own unit, matched by its arrival less the
// delay the host's truth records; read without the delay, each would name the next scan (by the
// stamp, 40 ms from it): published twice, and the scan itself unaccounted.
TEST(ChaosCheck, ANetemDelayIsTakenOffTheArrivalsOfTheUnitsSentDuringIt) {
  constexpr Nanos kDelay = 60'000'000;
  Input in = honest();
  const auto held = [](std::int64_t unit) { return unit >= 20 && unit < 30; };
  for (auto& s : in.samples) {
    const bool h = held(static_cast<std::int64_t>(s.seq));
    s.first_rx_ns = s.acquisition_ns + (h ? kDelay : 0) + 100'000;
    if (h) s.acquisition_ns += kDelay;  // mapped: follows the arrival
  }
  const Nanos at = kT0 + 20 * kPeriod, until = kT0 + 30 * kPeriod;
  in.unsynchronized[kTopic] = {{at, until + kDelay + kPeriod}};
  in.events.push_back(faults::FaultEvent{5, "host.network_delay", "lo", 2.0, 1.0, {{"ms", "60"}, {"jitter_ms", "0"}}});
  in.truths.push_back(truth::Log{});
  in.truths.back().header.device = "host";
  in.truths.back().faults.push_back(
      truth::FaultRecord{5, "host.network_delay", at, until, -1, "ms=60, jitter_ms=0, via=netem on lo, udp ports 2368"});
  Result r = check(in);
  EXPECT_TRUE(r.all_held()) << result_text(r);
  EXPECT_EQ(r.topics.at(kTopic).stamps_flagged, 10u);
  EXPECT_EQ(r.topics.at(kTopic).published_twice, 0u);
  // The same record from the LIDAR mocks' hold (their sends are the held ones): no delay taken off.
  in.truths.back().faults.back().detail = "ms=60, jitter_ms=0, via=lidar mocks (datagrams held, order kept)";
  r = check(in);
  EXPECT_FALSE(r.invariants.at("accounted"));
  EXPECT_GT(r.topics.at(kTopic).published_twice, 0u) << result_text(r);
}

}  // namespace
}  // namespace sensor_rig::rig::chaos
