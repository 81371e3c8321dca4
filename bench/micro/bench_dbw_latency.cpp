// bench_dbw_latency [--seconds=S] [--rate=HZ] (other --options, e.g. --benchmark_*, are ignored): the DDS bridge and the mock ECU on a socketpair in one
// process, a DDS command source at RATE_HZ (default 100) for SECONDS (default 10), then silence.
// Prints JSON: DDS command (source timestamp) -> CAN frame written p50/p99/max, take -> written,
// command silence -> first disengage frame on the bus (kernel receive time at the ECU), CPU share of
// the bridge's own two threads (CLOCK_THREAD_CPUTIME_ID over the bridge's run, SECONDS + 1.2 s;
// Cyclone's threads not included) and of the whole process while commands flow (bridge, mock ECU,
// command source, all DDS threads), and the process's peak RSS (memory flat over 10^6 commands).
#include <sys/resource.h>
#include <time.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>

#include "sensor_rig/dbw/bridge/defaults.hpp"
#include "sensor_rig/drivers/dbw/dds_bridge.hpp"
#include "sensor_rig/drivers/dbw/dds_domain.hpp"
#include "sensor_rig/drivers/dbw/dds_types.hpp"
#include "sensor_rig/dbw/can/candump.hpp"
#include "sensor_rig/dbw/mock/mock_runner.hpp"

namespace dbw = sensor_rig::dbw;
namespace dds = sensor_rig::dds;
using sensor_rig::Nanos;

int main(int argc, char** argv) {
  double seconds = 10.0;
  double rate = 100.0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--seconds=", 0) == 0) seconds = std::atof(a.c_str() + 10);
    if (a.rfind("--rate=", 0) == 0) rate = std::atof(a.c_str() + 7);
  }
  if (!(seconds > 0.0) || !(rate > 0.0)) {
    std::fprintf(stderr, "usage: bench_dbw_latency [--seconds=S] [--rate=HZ]\n");
    return 2;
  }
  if (std::getenv("ROS_DOMAIN_ID") == nullptr) ::setenv("ROS_DOMAIN_ID", "161", 1);
  const auto protocol = dbw::Protocol::load(dbw::default_protocol_config());
  auto ends = dbw::can::make_socketpair();  // named, not a structured binding: lambdas capture them
  auto& bridge_end = ends.first;
  auto& ecu_end = ends.second;
  const std::string log = "/tmp/bench_dbw_bus_" + std::to_string(::getpid()) + ".log";
  dbw::mock::MockEcu ecu(protocol, {});
  dbw::mock::RunOptions mo;
  mo.duration_s = seconds + 1.5;
  mo.log_path = log;
  std::thread ecu_thread([&] { dbw::mock::run_mock(ecu, *ecu_end, mo); });
  sensor_rig::drivers::DdsBridgeOptions bo;
  bo.duration_s = seconds + 1.2;
  sensor_rig::drivers::DdsBridgeStats stats;
  std::thread bridge_thread([&] { stats = sensor_rig::drivers::run_dds_bridge(protocol, *bridge_end, bo); });

  rusage r0{};
  ::getrusage(RUSAGE_SELF, &r0);
  // Command source (same as `rig dbw send`), remembering the last write time.
  dds::Participant participant(sensor_rig::drivers::domain_config());
  dds::Topic<sensor_rig::msg::DbwCommand> topic(participant, sensor_rig::drivers::kCmdTopic);
  dds::Writer<sensor_rig::msg::DbwCommand> writer(participant, topic);
  writer.wait_for_readers(1, 3000);
  sensor_rig::msg::DbwCommand c{};
  char frame_id[] = "base_link";
  c.header.frame_id = frame_id;
  const Nanos period = static_cast<Nanos>(1e9 / rate);
  const Nanos start = sensor_rig::monotonic_now_ns();
  Nanos last_write = 0;
  std::uint64_t seq = 0;
  for (Nanos next = start; next < start + static_cast<Nanos>(seconds * 1e9); next += period) {
    timespec ts{static_cast<time_t>(next / 1'000'000'000), static_cast<long>(next % 1'000'000'000)};
    ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
    last_write = sensor_rig::vehicle_now_ns();
    c.header.stamp = sensor_rig::msg::to_time(last_write);
    c.seq = ++seq;
    c.enable = seq > 1;
    c.steering_angle = 0.05;
    c.throttle = 0.2;
    writer.write(c, last_write);
  }
  rusage r1{};
  ::getrusage(RUSAGE_SELF, &r1);
  bridge_thread.join();
  ecu_thread.join();
  const double cpu_s = static_cast<double>(r1.ru_utime.tv_sec - r0.ru_utime.tv_sec + r1.ru_stime.tv_sec - r0.ru_stime.tv_sec) +
                       static_cast<double>(r1.ru_utime.tv_usec - r0.ru_utime.tv_usec + r1.ru_stime.tv_usec - r0.ru_stime.tv_usec) * 1e-6;
  // First steering frame with enable=0 on the bus after the last command was written.
  std::ifstream in(log);
  dbw::can::CandumpReader reader(in);
  dbw::can::LogRecord rec;
  double silence_ms = -1;
  while (reader.next(rec)) {
    if (rec.frame.id == 0x100 && rec.stamp > last_write && (rec.frame.data[1] & 0x10) == 0) {
      silence_ms = static_cast<double>(rec.stamp - last_write) * 1e-6;
      break;
    }
  }
  std::remove(log.c_str());
  std::printf("{\"rate_hz\":%.0f,\"seconds\":%.1f,\"commands\":%llu,\"cmd_to_can_us\":{\"p50\":%.1f,\"p99\":%.1f,\"max\":%.1f},"
              "\"take_to_send_us\":{\"p50\":%.1f,\"p99\":%.1f},\"silence_to_disengage_frame_ms\":%.3f,"
              "\"timeout_ms\":%.0f,\"tx_period_ms\":%.0f,\"bridge_threads_cpu_percent_of_one_core\":%.2f,"
              "\"process_cpu_percent_of_one_core\":%.2f,\"max_rss_kb\":%ld}\n",
              rate, seconds, static_cast<unsigned long long>(stats.commands), stats.latency_p50_us, stats.latency_p99_us,
              stats.latency_max_us, stats.take_to_send_p50_us, stats.take_to_send_p99_us, silence_ms,
              static_cast<double>(protocol.timing().command_timeout_ns) * 1e-6,
              static_cast<double>(protocol.timing().tx_period_ns) * 1e-6,
              100.0 * stats.bridge_threads_cpu_s / bo.duration_s, 100.0 * cpu_s / seconds, r1.ru_maxrss);
  return 0;
}
