// bench_lidar_sources --source=udp|packet --ports=P1,P2,... [--interface=IF] [--sensors=ADDR1,ADDR2,...]
//                     [--retire-ms=MS] [--seconds=S]
// The LIDAR data-port sources under a real load: one receive thread per port (as the LIDAR node
// runs one per sensor), each with its own UdpSource or RingSource, receiving only (no decoding) for
// SECONDS (default 60). --sensors: each port's sensor address (the ring's filter; as sensor_address);
// --retire-ms: the ring's block retire timeout (default RingSourceConfig's). Prints one JSON line per port: datagrams and bytes received, the source's
// drop counters (UDP: SO_RXQ_OVFL; ring: PACKET_STATISTICS drops and freeze count, reassembly
// drops), the thread's CPU (CLOCK_THREAD_CPUTIME_ID: share of wall time, and µs per datagram), and
// the delivery delay (the time receive() handed a datagram over minus its kernel receive stamp:
// queueing, the ring's block retire timeout, wake-up); then one line with the
// process's CPU and the host's softirq/system share over the run (/proc/stat; kernel copies into
// the ring or socket happen there, not in our threads) and the load average.
// scripts/bench_lidar_sources.sh runs it against three synthetic LIDARs across a veth pair.
#include <arpa/inet.h>
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/lidar/ring_source.hpp"
#include "sensor_rig/lidar/udp_source.hpp"

namespace lidar = sensor_rig::lidar;
using sensor_rig::Nanos;

namespace {

struct PortResult {
  std::uint16_t port = 0;
  std::uint64_t packets = 0, bytes = 0, drops = 0, freeze_q = 0, ring_packets = 0, reassembled = 0,
                reassembly_dropped = 0, filtered = 0, truncated = 0;
  Nanos cpu_ns = 0;
  std::vector<Nanos> delays;  // per datagram: handed to us - kernel receive stamp
};

Nanos percentile(std::vector<Nanos>& v, double q) {
  if (v.empty()) return 0;
  const auto k = static_cast<std::size_t>(q * static_cast<double>(v.size() - 1));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

Nanos thread_cpu_ns() { return sensor_rig::clock_ns(CLOCK_THREAD_CPUTIME_ID); }

// /proc/stat "cpu" line: {total, system, softirq} jiffies.
std::vector<unsigned long long> cpu_jiffies() {
  std::ifstream f("/proc/stat");
  std::string cpu;
  unsigned long long v[10] = {};
  f >> cpu;
  for (auto& x : v) f >> x;
  unsigned long long total = 0;
  for (auto x : v) total += x;
  return {total, v[2], v[6]};
}

template <class Source>
void receive_loop(Source& src, const std::atomic<bool>& stop, PortResult& out) {
  lidar::SlotArena arena(64, 65536);
  out.delays.reserve(1 << 20);
  const Nanos cpu0 = thread_cpu_ns();
  while (!stop.load(std::memory_order_relaxed)) {
    const auto r = src.receive(arena.slots(), 50);
    const Nanos now = r.count > 0 ? sensor_rig::vehicle_now_ns() : 0;
    for (std::size_t i = 0; i < r.count; ++i) {
      out.bytes += arena.slots()[i].size;
      if (out.delays.size() < out.delays.capacity()) out.delays.push_back(now - arena.slots()[i].rx_ns);
    }
    out.packets += r.count;
  }
  out.cpu_ns = thread_cpu_ns() - cpu0;
}

std::vector<std::uint16_t> parse_ports(const std::string& text) {
  std::vector<std::uint16_t> ports;
  std::stringstream ss(text);
  for (std::string p; std::getline(ss, p, ',');) {
    const long v = std::strtol(p.c_str(), nullptr, 10);
    if (v <= 0 || v > 65535) return {};
    ports.push_back(static_cast<std::uint16_t>(v));
  }
  return ports;
}

}  // namespace

int main(int argc, char** argv) {
  std::string source = "udp", interface, sensors_text;
  std::vector<std::uint16_t> ports;
  double seconds = 60.0;
  int retire_ms = lidar::RingSourceConfig{}.retire_timeout_ms;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](const char* key) { return a.substr(std::string(key).size()); };
    if (a.rfind("--source=", 0) == 0) source = value("--source=");
    if (a.rfind("--interface=", 0) == 0) interface = value("--interface=");
    if (a.rfind("--sensors=", 0) == 0) sensors_text = value("--sensors=");
    if (a.rfind("--ports=", 0) == 0) ports = parse_ports(value("--ports="));
    if (a.rfind("--seconds=", 0) == 0) seconds = std::atof(value("--seconds=").c_str());
    if (a.rfind("--retire-ms=", 0) == 0) retire_ms = std::atoi(value("--retire-ms=").c_str());
  }
  if ((source != "udp" && source != "packet") || ports.empty() || !(seconds > 0) ||
      (source == "packet" && interface.empty())) {
    std::fprintf(stderr,
                 "usage: bench_lidar_sources --source=udp|packet --ports=P1,P2,... [--interface=IF (packet)] "
                 "[--sensors=IPV4,... (one per port)] [--retire-ms=MS] [--seconds=S]\n");
    return 2;
  }
  std::vector<std::uint32_t> sensor_hosts(ports.size(), 0);
  if (!sensors_text.empty()) {
    std::stringstream ss(sensors_text);
    std::size_t i = 0;
    for (std::string addr; std::getline(ss, addr, ','); ++i) {
      in_addr a{};
      if (i >= ports.size() || ::inet_pton(AF_INET, addr.c_str(), &a) != 1) {
        std::fprintf(stderr, "bench_lidar_sources: --sensors: '%s' is not an IPv4 address, or more than ports\n",
                     addr.c_str());
        return 2;
      }
      sensor_hosts[i] = ntohl(a.s_addr);
    }
  }

  std::vector<lidar::UdpSource> udp;
  std::vector<lidar::RingSource> rings;
  try {
    for (std::size_t i = 0; i < ports.size(); ++i) {
      const std::uint16_t port = ports[i];
      if (source == "udp") {
        udp.emplace_back(lidar::UdpSourceConfig{{"0.0.0.0", port}, 8 << 20, 64, false});
      } else {
        lidar::RingSourceConfig c;
        c.interface = interface;
        c.port = port;
        c.sensor_host = sensor_hosts[i];
        c.retire_timeout_ms = retire_ms;
        rings.emplace_back(c);
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_lidar_sources: %s\n", e.what());
    return 1;
  }

  std::atomic<bool> stop{false};
  std::vector<PortResult> results(ports.size());
  std::vector<std::thread> threads;
  const auto jiffies0 = cpu_jiffies();
  rusage ru0{};
  ::getrusage(RUSAGE_SELF, &ru0);
  const Nanos t0 = sensor_rig::monotonic_now_ns();
  for (std::size_t i = 0; i < ports.size(); ++i) {
    results[i].port = ports[i];
    if (source == "udp") {
      threads.emplace_back([&, i] { receive_loop(udp[i], stop, results[i]); });
    } else {
      threads.emplace_back([&, i] { receive_loop(rings[i], stop, results[i]); });
    }
  }
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  stop.store(true);
  for (auto& t : threads) t.join();
  const Nanos wall = sensor_rig::monotonic_now_ns() - t0;
  rusage ru1{};
  ::getrusage(RUSAGE_SELF, &ru1);
  const auto jiffies1 = cpu_jiffies();

  for (std::size_t i = 0; i < ports.size(); ++i) {
    auto& r = results[i];
    if (source == "udp") {
      const auto& s = udp[i].stats();
      r.drops = s.kernel_drops;
      r.truncated = s.truncated;
    } else {
      rings[i].refresh_kernel_stats();
      const auto& s = rings[i].stats();
      r.drops = s.ring_drops;
      r.freeze_q = s.ring_freeze_q;
      r.ring_packets = s.ring_packets;
      r.reassembled = s.reassembly.reassembled;
      r.reassembly_dropped = s.reassembly.dropped_total();
      r.filtered = s.filtered;
      r.truncated = s.truncated;
    }
    std::printf(
        "{\"source\":\"%s\",\"retire_ms\":%d,\"port\":%u,\"seconds\":%.1f,\"packets\":%llu,\"packets_per_s\":%.0f,\"mbytes_per_s\":%.2f,"
        "\"drops\":%llu,\"freeze_q\":%llu,\"ring_frames\":%llu,\"reassembled\":%llu,\"reassembly_dropped\":%llu,"
        "\"filtered\":%llu,\"truncated\":%llu,\"cpu_pct\":%.2f,\"cpu_us_per_packet\":%.2f,"
        "\"delay_us_p50\":%.0f,\"delay_us_p99\":%.0f,\"delay_us_max\":%.0f}\n",
        source.c_str(), source == "packet" ? retire_ms : 0, r.port, static_cast<double>(wall) * 1e-9, static_cast<unsigned long long>(r.packets),
        static_cast<double>(r.packets) / (static_cast<double>(wall) * 1e-9),
        static_cast<double>(r.bytes) / (static_cast<double>(wall) * 1e-3), static_cast<unsigned long long>(r.drops),
        static_cast<unsigned long long>(r.freeze_q), static_cast<unsigned long long>(r.ring_packets),
        static_cast<unsigned long long>(r.reassembled), static_cast<unsigned long long>(r.reassembly_dropped),
        static_cast<unsigned long long>(r.filtered), static_cast<unsigned long long>(r.truncated),
        100.0 * static_cast<double>(r.cpu_ns) / static_cast<double>(wall),
        r.packets > 0 ? static_cast<double>(r.cpu_ns) * 1e-3 / static_cast<double>(r.packets) : 0.0,
        static_cast<double>(percentile(r.delays, 0.5)) * 1e-3, static_cast<double>(percentile(r.delays, 0.99)) * 1e-3,
        static_cast<double>(percentile(r.delays, 1.0)) * 1e-3);
  }
  auto tv_ns = [](const timeval& t) { return static_cast<Nanos>(t.tv_sec) * 1'000'000'000LL + t.tv_usec * 1000LL; };
  const Nanos proc_cpu = tv_ns(ru1.ru_utime) - tv_ns(ru0.ru_utime) + tv_ns(ru1.ru_stime) - tv_ns(ru0.ru_stime);
  const double total = static_cast<double>(jiffies1[0] - jiffies0[0]);
  double load[3] = {0, 0, 0};
  if (::getloadavg(load, 3) != 3) load[0] = load[1] = load[2] = -1;
  std::printf(
      "{\"source\":\"%s\",\"summary\":true,\"process_cpu_pct\":%.2f,\"host_system_pct\":%.2f,\"host_softirq_pct\":%.2f,"
      "\"loadavg\":[%.2f,%.2f,%.2f]}\n",
      source.c_str(), 100.0 * static_cast<double>(proc_cpu) / static_cast<double>(wall),
      total > 0 ? 100.0 * static_cast<double>(jiffies1[1] - jiffies0[1]) / total : 0.0,
      total > 0 ? 100.0 * static_cast<double>(jiffies1[2] - jiffies0[2]) / total : 0.0, load[0], load[1], load[2]);
  return 0;
}
