// `record:` on the receive thread, before and after the writer thread (issue 11): what the receive
// thread pays per datagram, in wall time (a blocking writev counts), into rotating pcap files on
// the root disk (/var/tmp). Sizes: a Velodyne packet (1206 B) and an OS-1-128 1024x20 datagram
// (24896 B).
// - BM_PcapWriteOnReceiveThread: PcapRecorder::write (one writev per packet), as before.
// - BM_QueuePushToWriterThread: RecorderThread::push (a copy into the queue); the writer thread
//   writes meanwhile. Whenever half the queue may be full the timing pauses until the writer caught
//   up, so the figure is a receive thread whose writer keeps up (no drops: counter `queue_dropped`).
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "sensor_rig/lidar/pcap_recorder.hpp"
#include "sensor_rig/lidar/recorder_thread.hpp"

namespace lidar = sensor_rig::lidar;
using sensor_rig::Nanos;

namespace {

struct TempDir {
  std::filesystem::path path;
  TempDir() {
    char tmpl[] = "/var/tmp/rig-bench-rec-XXXXXX";
    path = ::mkdtemp(tmpl);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
};

lidar::PcapRecorderConfig config(const TempDir& d) {
  lidar::PcapRecorderConfig c;
  c.directory = d.path.string();
  c.max_file_bytes = 64ULL << 20;
  c.max_file_ns = 0;
  c.max_files = 4;
  return c;
}

const lidar::DatagramHeaders kHeaders{lidar::UdpAddressing{0x0A000005, 2368, 0x0A000001, 2368}, {}};

void BM_PcapWriteOnReceiveThread(benchmark::State& state) {
  TempDir d;
  lidar::PcapRecorder rec(config(d));
  const std::vector<std::byte> packet(static_cast<std::size_t>(state.range(0)), std::byte{0x5a});
  Nanos t = 1'700'000'000'000'000'000LL;
  for (auto _ : state) benchmark::DoNotOptimize(rec.write(packet, t += 1000, kHeaders));
  state.counters["dropped"] = static_cast<double>(rec.stats().dropped);
  state.SetItemsProcessed(state.iterations());
}

void BM_QueuePushToWriterThread(benchmark::State& state) {
  TempDir d;
  constexpr std::size_t kQueueBytes = 16 << 20;
  lidar::RecorderThread rec(std::make_unique<lidar::PcapRecorder>(config(d)), kQueueBytes, 1'000'000);
  const std::vector<std::byte> packet(static_cast<std::size_t>(state.range(0)), std::byte{0x5a});
  const std::uint64_t batch = kQueueBytes / 2 / (packet.size() + 128);
  Nanos t = 1'700'000'000'000'000'000LL;
  std::uint64_t pushed = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(rec.push(packet, t += 1000, kHeaders));
    if (++pushed % batch == 0) {
      state.PauseTiming();
      while (rec.status().sink.stats.packets + rec.status().dropped() < pushed)
        std::this_thread::sleep_for(std::chrono::microseconds(200));
      state.ResumeTiming();
    }
  }
  rec.close();
  state.counters["queue_dropped"] = static_cast<double>(rec.status().queue_dropped);
  state.SetItemsProcessed(state.iterations());
}

}  // namespace

BENCHMARK(BM_PcapWriteOnReceiveThread)->Arg(1206)->Arg(24896)->UseRealTime()->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_QueuePushToWriterThread)->Arg(1206)->Arg(24896)->UseRealTime()->Unit(benchmark::kMicrosecond);
BENCHMARK_MAIN();
