// Hot paths of the dbw stack: signal decode, candump parsing, E2E, the feedback loss count, and the
// bridge's per-command work.
#include <benchmark/benchmark.h>

#include <array>
#include <string>

#include "sensor_rig/dbw/bridge/defaults.hpp"
#include "sensor_rig/dbw/bridge/bridge_core.hpp"
#include "sensor_rig/dbw/bridge/frame_loss_counter.hpp"
#include "sensor_rig/dbw/can/candump.hpp"
#include "sensor_rig/dbw/dbc/codec.hpp"
#include "sensor_rig/dbw/dbc/parser.hpp"

namespace dbw = sensor_rig::dbw;

namespace {

constexpr const char* kWheels = R"(
BO_ 170 WHEEL_SPEEDS: 8 XXX
 SG_ WHEEL_SPEED_FR : 6|15@0+ (0.01,-67.67) [0|0] "km/h" XXX
 SG_ WHEEL_SPEED_FL : 22|15@0+ (0.01,-67.67) [0|0] "km/h" XXX
 SG_ WHEEL_SPEED_RR : 38|15@0+ (0.01,-67.67) [0|0] "km/h" XXX
 SG_ WHEEL_SPEED_RL : 54|15@0+ (0.01,-67.67) [0|0] "km/h" XXX
)";

void BM_DecodeFourMotorolaSignals(benchmark::State& st) {
  const auto db = dbw::dbc::parse(kWheels);
  const auto& m = db.messages[0];
  const std::array<std::uint8_t, 8> d = {0x25, 0xB5, 0x25, 0xB5, 0x25, 0xA0, 0x25, 0x8D};
  for (auto _ : st) {
    double sum = 0;
    for (const auto& s : m.signals) sum += *dbw::dbc::decode(s, d);
    benchmark::DoNotOptimize(sum);
  }
}
BENCHMARK(BM_DecodeFourMotorolaSignals);

void BM_CandumpParseLine(benchmark::State& st) {
  const std::string line = "(46408.589503) can0 0AA#25B525B525A0258D";
  dbw::can::LogRecord r;
  for (auto _ : st) benchmark::DoNotOptimize(dbw::can::parse_candump_line(line, r));
}
BENCHMARK(BM_CandumpParseLine);

dbw::safety::E2eConfig p01(std::uint16_t data_id) {
  dbw::safety::E2eConfig c;
  c.profile = dbw::safety::E2eProfile::kP01;
  c.data_id = data_id;
  return c;
}

void BM_E2eP01ProtectAndCheck(benchmark::State& st) {
  const auto c = p01(0x100);
  dbw::safety::E2eSender tx(c);
  dbw::safety::E2eChecker rx(c);
  std::array<std::uint8_t, 8> d{};
  for (auto _ : st) {
    tx.protect(d);
    benchmark::DoNotOptimize(rx.check(d));
  }
}
BENCHMARK(BM_E2eP01ProtectAndCheck);

// One feedback frame's loss accounting (checked, then counted): every good frame learns the period
// from the median of the latest intervals.
void BM_FrameLossCounterOnFrame(benchmark::State& st) {
  const auto c = p01(0x181);
  dbw::safety::E2eSender tx(c);
  dbw::safety::E2eChecker rx(c);
  dbw::FrameLossCounter counter(c);
  std::array<std::uint8_t, 8> d{};
  sensor_rig::Nanos t = 0;
  for (auto _ : st) {
    tx.protect(d);
    t += 10'000'000 + (t / 7) % 1'000'000;  // a 10 ms period with jitter
    counter.on_frame(d, rx.check(d), t);
  }
  benchmark::DoNotOptimize(counter.lost());
}
BENCHMARK(BM_FrameLossCounterOnFrame);

// One command through validation, safety, encoding and E2E into the three frames of the protocol.
void BM_BridgeCommandToFrames(benchmark::State& st) {
  const auto p = dbw::Protocol::load(dbw::default_protocol_config());
  dbw::BridgeCore core(p);
  sensor_rig::Nanos now = 1'000'000'000'000;
  core.safety().on_ecu_status({true, false, false, false, 0}, now);
  std::vector<dbw::can::Frame> out;
  out.reserve(8);
  std::uint64_t seq = 0;
  for (auto _ : st) {
    now += 10'000'000;
    core.safety().on_ecu_status({true, true, false, false, 0}, now);
    dbw::safety::Command c;
    c.stamp = now;
    c.seq = ++seq;
    c.enable = true;
    c.steering_angle = 0.1;
    c.throttle = 0.2;
    core.on_command(c, now, now);
    out.clear();
    core.frames(now, out);
    (void)core.safety().take_events();
    benchmark::DoNotOptimize(out.data());
  }
}
BENCHMARK(BM_BridgeCommandToFrames);

}  // namespace

BENCHMARK_MAIN();
