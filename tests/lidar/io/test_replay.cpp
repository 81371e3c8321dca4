// Mock sender end to end on loopback: a synthetic capture written with libpcap's pcap_dump is
// replayed to real UDP sockets; counts, timing, rate, loop, faults and bad captures are checked.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <pcap/pcap.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>
#include <vector>

#include "sensor_rig/lidar/mock/replay.hpp"
#include "sensor_rig/lidar/udp_source.hpp"

namespace sensor_rig::lidar::mock {
namespace {

namespace fs = std::filesystem;

struct CapturedPacket {
  Nanos time_ns;
  bool position;
  std::vector<std::byte> bytes;
};

// Ethernet + IPv4 + UDP around each payload, as a Velodyne at 192.168.1.201 sends them.
void write_pcap(const std::string& path, const std::vector<CapturedPacket>& packets) {
  pcap_t* dead = pcap_open_dead_with_tstamp_precision(DLT_EN10MB, 65535, PCAP_TSTAMP_PRECISION_MICRO);
  ASSERT_NE(dead, nullptr);
  pcap_dumper_t* dump = pcap_dump_open(dead, path.c_str());
  ASSERT_NE(dump, nullptr) << pcap_geterr(dead);
  for (const auto& p : packets) {
    const std::uint16_t port = p.position ? 8308 : 2368;
    std::vector<std::uint8_t> f(42 + p.bytes.size(), 0);
    std::fill(f.begin(), f.begin() + 6, 0xFF);  // broadcast
    f[6] = 0x60;                                 // Velodyne OUI 60:76:88
    f[7] = 0x76;
    f[8] = 0x88;
    f[12] = 0x08;  // IPv4
    std::uint8_t* ip = f.data() + 14;
    ip[0] = 0x45;
    const auto ip_len = static_cast<std::uint16_t>(20 + 8 + p.bytes.size());
    ip[2] = static_cast<std::uint8_t>(ip_len >> 8);
    ip[3] = static_cast<std::uint8_t>(ip_len);
    ip[8] = 64;
    ip[9] = 17;
    const std::uint8_t src[4] = {192, 168, 1, 201};
    std::copy(src, src + 4, ip + 12);
    std::fill(ip + 16, ip + 20, 0xFF);
    std::uint32_t sum = 0;
    for (int i = 0; i < 20; i += 2) sum += static_cast<std::uint32_t>(ip[i] << 8 | ip[i + 1]);
    while (sum >> 16) sum = (sum & 0xFFFF) + (sum >> 16);
    ip[10] = static_cast<std::uint8_t>(~sum >> 8);
    ip[11] = static_cast<std::uint8_t>(~sum);
    std::uint8_t* udp = ip + 20;
    udp[0] = static_cast<std::uint8_t>(port >> 8);
    udp[1] = static_cast<std::uint8_t>(port);
    udp[2] = udp[0];
    udp[3] = udp[1];
    const auto udp_len = static_cast<std::uint16_t>(8 + p.bytes.size());
    udp[4] = static_cast<std::uint8_t>(udp_len >> 8);
    udp[5] = static_cast<std::uint8_t>(udp_len);
    std::memcpy(udp + 8, p.bytes.data(), p.bytes.size());
    pcap_pkthdr h{};
    h.ts.tv_sec = static_cast<time_t>(p.time_ns / 1'000'000'000);
    h.ts.tv_usec = static_cast<suseconds_t>(p.time_ns % 1'000'000'000 / 1000);
    h.caplen = h.len = static_cast<bpf_u_int32>(f.size());
    pcap_dump(reinterpret_cast<u_char*>(dump), &h, f.data());
  }
  pcap_dump_close(dump);
  pcap_close(dead);
}

// `seconds` of a synthetic VLP-16 with a position packet every 100 ms; times rounded to the µs
// the pcap records keep.
std::vector<CapturedPacket> synthetic_capture(double seconds) {
  SyntheticConfig c;
  c.start_ns = 1'700'000'000'000'000'000LL;
  c.position_period_ns = 100'000'000;
  SyntheticVelodyne s(c, Scene::standard());
  std::vector<CapturedPacket> out;
  while (true) {
    const SyntheticPacket p = s.next();
    if (p.time_ns - c.start_ns > static_cast<Nanos>(seconds * 1e9)) break;
    out.push_back({p.time_ns / 1000 * 1000, p.position, {p.bytes.begin(), p.bytes.end()}});
  }
  return out;
}

struct Received {
  std::vector<std::vector<std::byte>> data;
  std::vector<Nanos> data_rx;
  std::size_t position = 0;
};

class Replay : public testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rig_replay_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    capture_ = synthetic_capture(0.3);
    path_ = (dir_ / "synthetic_vlp16.pcap").string();
    write_pcap(path_, capture_);
    for (const auto& p : capture_) (p.position ? n_position_ : n_data_) += 1;
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Replays `path` with `o` while receiving on two loopback sockets; returns what arrived.
  Received run(const ReplayOptions& o, ReplayStats& stats, const std::string& path = {}) {
    UdpSourceConfig cfg;
    cfg.bind = {"127.0.0.1", 0};
    cfg.receive_buffer_bytes = 16 << 20;
    UdpSource data(cfg), position(cfg);
    const std::vector<Endpoint> dests{{"127.0.0.1", data.port()}, {"127.0.0.1", position.port()}};
    UdpSender sender(dests);
    PcapStream stream(path.empty() ? path_ : path);
    std::atomic<bool> done{false};
    std::thread tx([&] {
      stats = run_replay(stream, sender, o);
      done = true;
    });
    Received r;
    SlotArena arena(64);
    int idle = 0;
    while (idle < 2) {  // until 2 × 50 ms without anything after the sender finished
      const RecvResult res = data.receive(arena.slots(), 50);
      for (std::size_t i = 0; i < res.count; ++i) {
        const auto b = arena.slots()[i].bytes();
        r.data.emplace_back(b.begin(), b.end());
        r.data_rx.push_back(arena.slots()[i].rx_ns);
      }
      const RecvResult pr = position.receive(arena.slots(), 0);
      r.position += pr.count;
      idle = res.count == 0 && pr.count == 0 && done ? idle + 1 : 0;
    }
    tx.join();
    EXPECT_EQ(data.stats().kernel_drops, 0u);
    return r;
  }

  std::vector<std::byte> original_data(std::size_t i) const {
    std::size_t k = 0;
    for (const auto& p : capture_) {
      if (p.position) continue;
      if (k++ == i) return p.bytes;
    }
    return {};
  }

  fs::path dir_;
  std::string path_;
  std::vector<CapturedPacket> capture_;
  std::size_t n_data_ = 0, n_position_ = 0;
};

TEST_F(Replay, SendsEveryPayloadAtRecordedTiming) {
  ReplayOptions o;
  o.send_position = true;
  ReplayStats st;
  const Received r = run(o, st);
  EXPECT_EQ(st.read, capture_.size());
  EXPECT_EQ(st.sent, capture_.size());
  EXPECT_TRUE(st.stream_error.empty());
  ASSERT_EQ(r.data.size(), n_data_);
  EXPECT_EQ(r.position, n_position_);
  for (std::size_t i = 0; i < r.data.size(); ++i) ASSERT_EQ(r.data[i], original_data(i)) << "packet " << i;
  // Arrival span matches the capture's span; packets are spaced at ~1.33 ms on average. The
  // schedule is absolute: the span is off by at most how late the sender says it ran (its own
  // deadlines: a wrong schedule is not excused by them), which a loaded host makes tens of ms.
  const double span_capture = static_cast<double>(capture_.back().time_ns - capture_.front().time_ns);
  const double span_rx = static_cast<double>(r.data_rx.back() - r.data_rx.front());
  const double late = static_cast<double>(st.max_late_ns);
  EXPECT_NEAR(span_rx, span_capture, 0.1 * span_capture + late) << "sent up to " << late * 1e-6 << " ms late";
  EXPECT_GE(span_rx, 0.9 * span_capture - late);
}

TEST_F(Replay, RateFactorScalesTiming) {
  ReplayOptions o;
  o.rate = 3.0;
  ReplayStats st;
  const Received r = run(o, st);
  ASSERT_EQ(r.data.size(), n_data_);
  EXPECT_EQ(r.position, 0u);
  EXPECT_EQ(st.skipped_position, n_position_);
  const double span_capture = static_cast<double>(capture_.back().time_ns - capture_.front().time_ns);
  const double span_rx = static_cast<double>(r.data_rx.back() - r.data_rx.front());
  const double late = static_cast<double>(st.max_late_ns);  // as above
  EXPECT_NEAR(span_rx, span_capture / 3.0, 0.15 * span_capture / 3.0 + late) << "sent up to " << late * 1e-6 << " ms late";
}

TEST_F(Replay, LoopsAndStopsAtPacketLimit) {
  ReplayOptions o;
  o.rate = 10.0;
  o.loop = true;
  o.max_packets = 2 * capture_.size() + 10;
  ReplayStats st;
  const Received r = run(o, st);
  EXPECT_EQ(st.loops, 2u);
  EXPECT_EQ(st.read, o.max_packets);
  EXPECT_GE(r.data.size(), 2 * n_data_);
  EXPECT_EQ(r.data[n_data_], original_data(0)) << "second pass starts with the first packet";
  EXPECT_TRUE(std::is_sorted(r.data_rx.begin(), r.data_rx.end()));
}

TEST_F(Replay, DropFaultIsCountedExactly) {
  ReplayOptions o;
  o.rate = 10.0;
  o.faults.drop_rate = 0.2;
  o.faults.seed = 11;
  ReplayStats st;
  const Received r = run(o, st);
  EXPECT_EQ(r.data.size() + st.faults.dropped, n_data_);
  EXPECT_GT(st.faults.dropped, n_data_ / 10);
  EXPECT_LT(st.faults.dropped, n_data_ * 3 / 10);
  // What arrives is an in-order subsequence of the capture.
  std::size_t k = 0;
  for (const auto& pkt : r.data) {
    while (k < n_data_ && original_data(k) != pkt) ++k;
    ASSERT_LT(k, n_data_) << "received a packet not in the capture, or out of order";
  }
}

TEST_F(Replay, CorruptTruncateDuplicateFaults) {
  ReplayOptions o;
  o.rate = 10.0;
  o.faults.corrupt_rate = 0.1;
  o.faults.seed = 3;
  ReplayStats st;
  Received r = run(o, st);
  ASSERT_EQ(r.data.size(), n_data_);
  std::size_t differing = 0;
  for (std::size_t i = 0; i < n_data_; ++i) differing += r.data[i] != original_data(i) ? 1 : 0;
  EXPECT_EQ(differing, st.faults.corrupted);
  EXPECT_GT(st.faults.corrupted, 0u);

  o.faults = {};
  o.faults.truncate_rate = 0.1;
  r = run(o, st);
  ASSERT_EQ(r.data.size(), n_data_);
  std::size_t short_ones = 0;
  for (std::size_t i = 0; i < n_data_; ++i) {
    if (r.data[i].size() == 1206) continue;
    ++short_ones;
    const auto orig = original_data(i);
    EXPECT_TRUE(std::equal(r.data[i].begin(), r.data[i].end(), orig.begin())) << "truncation keeps a prefix";
  }
  EXPECT_EQ(short_ones, st.faults.truncated);
  EXPECT_GT(short_ones, 0u);

  o.faults = {};
  o.faults.duplicate_rate = 0.1;
  r = run(o, st);
  EXPECT_EQ(r.data.size(), n_data_ + st.faults.duplicated);
  EXPECT_GT(st.faults.duplicated, 0u);
}

TEST_F(Replay, ReorderSwapsNeighbours) {
  ReplayOptions o;
  o.rate = 10.0;
  o.faults.reorder_rate = 0.1;
  o.faults.seed = 5;
  ReplayStats st;
  const Received r = run(o, st);
  ASSERT_EQ(r.data.size(), n_data_);
  // Index of each arrival in the capture (payloads are unique: timestamps differ).
  std::vector<std::size_t> idx;
  for (const auto& pkt : r.data) {
    std::size_t k = 0;
    while (k < n_data_ && original_data(k) != pkt) ++k;
    ASSERT_LT(k, n_data_);
    idx.push_back(k);
  }
  std::size_t inversions = 0;
  for (std::size_t i = 1; i < idx.size(); ++i) inversions += idx[i] < idx[i - 1] ? 1 : 0;
  EXPECT_GT(st.faults.reordered, 0u);
  EXPECT_LE(inversions, st.faults.reordered);
  EXPECT_GE(inversions + 1, st.faults.reordered);  // a packet held at the very end goes out last
  auto sorted = idx;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], i) << "lost or duplicated packets";
}

// Each stall shifts the schedule by its length; the gap it leaves on the wire is that minus how late
// the sender already was before it (60 ms stalls counted as > 50 ms gaps failed on a loaded CI host:
// the sender ran > 10 ms late). 200 ms stalls, gaps > 100 ms: a sender 100 ms late, or descheduled
// for 100 ms, is what it takes to miscount.
TEST_F(Replay, StallInsertsGaps) {
  ReplayOptions o;
  o.faults.stall_ns = 200'000'000;
  o.faults.stall_every_ns = 100'000'000;
  ReplayStats st;
  const Received r = run(o, st);
  ASSERT_EQ(r.data.size(), n_data_);
  std::size_t gaps = 0;
  for (std::size_t i = 1; i < r.data_rx.size(); ++i) gaps += r.data_rx[i] - r.data_rx[i - 1] > 100'000'000 ? 1 : 0;
  Nanos last_data = 0;  // position packets are skipped here, so only data packets meet the injector
  for (const auto& p : capture_) last_data = p.position ? last_data : p.time_ns;
  const Nanos span = last_data - capture_.front().time_ns;
  EXPECT_EQ(st.faults.stalls, static_cast<std::uint64_t>(span / 100'000'000));  // at 0.1 s, 0.2 s, ...
  EXPECT_GE(st.faults.stalls, 2u);
  EXPECT_EQ(gaps, st.faults.stalls);
}

TEST_F(Replay, TruncatedCaptureEndsWithError) {
  const auto size = fs::file_size(path_);
  const std::string cut = (dir_ / "cut.pcap").string();
  fs::copy_file(path_, cut);
  fs::resize_file(cut, size / 2 + 77);  // mid-record
  ReplayOptions o;
  o.rate = 10.0;
  ReplayStats st;
  const Received r = run(o, st, cut);
  EXPECT_FALSE(st.stream_error.empty());
  EXPECT_GT(r.data.size(), n_data_ / 3);
  EXPECT_LT(r.data.size(), n_data_);
}

TEST_F(Replay, GarbageFileIsRejectedOnOpen) {
  const std::string junk = (dir_ / "junk.pcap").string();
  std::ofstream(junk) << "this is not a capture";
  EXPECT_THROW(PcapStream{junk}, std::exception);
}

TEST(FaultConfig, Validates) {
  FaultConfig f;
  EXPECT_NO_THROW(f.validate());
  EXPECT_FALSE(f.any());
  f.drop_rate = 1.5;
  EXPECT_THROW(f.validate(), std::invalid_argument);
  f = {};
  f.stall_ns = 5;
  EXPECT_THROW(f.validate(), std::invalid_argument);
  f.stall_every_ns = 10;
  EXPECT_NO_THROW(f.validate());
  EXPECT_TRUE(f.any());
}

// The `rig lidar replay` command as a process: synthetic VLP-16 for 0.5 s.
TEST(ReplayCli, SyntheticSensorAtRealRate) {
  const char* bin = std::getenv("RIG_BIN");
  if (bin == nullptr || !fs::exists(bin)) GTEST_SKIP() << "RIG_BIN (build/rig) not built; skipping the CLI test";
  UdpSourceConfig cfg;
  cfg.bind = {"127.0.0.1", 0};
  cfg.receive_buffer_bytes = 16 << 20;
  UdpSource data(cfg), position(cfg);
  const std::string cmd = std::string(bin) + " lidar replay --synthetic VLP-16 --to 127.0.0.1:" +
                          std::to_string(data.port()) + " --position-port " + std::to_string(position.port()) +
                          " --duration 0.5 --json 2>/dev/null";
  FILE* proc = ::popen(cmd.c_str(), "r");
  ASSERT_NE(proc, nullptr);
  SlotArena arena(64);
  std::size_t got = 0, pos = 0;
  std::vector<Nanos> rx;
  for (int idle = 0; idle < 5;) {
    const RecvResult r = data.receive(arena.slots(), 100);
    for (std::size_t i = 0; i < r.count; ++i) rx.push_back(arena.slots()[i].rx_ns);
    got += r.count;
    pos += position.receive(arena.slots(), 0).count;
    idle = r.count == 0 ? idle + 1 : 0;
  }
  char line[1024] = {};
  const bool have_line = std::fgets(line, sizeof line, proc) != nullptr;
  EXPECT_EQ(::pclose(proc), 0);
  ASSERT_TRUE(have_line);
  EXPECT_NE(std::string(line).find("\"sent_data\":" + std::to_string(got) + ","), std::string::npos) << line;
  // Its own account of how late it sent (absolute schedule): a loaded host's lateness excused,
  // a wrong rate not (its deadlines would be wrong, not late).
  const std::string text(line);
  const auto at = text.find("\"max_late_ms\":");
  ASSERT_NE(at, std::string::npos) << line;
  const double late_ns = std::stod(text.substr(at + 14)) * 1e6;
  // 0.5 s of a VLP-16 (753.5 packets/s); the packets the last late ones did not get out in time.
  EXPECT_NEAR(static_cast<double>(got), 0.5 * 753.5, 0.05 * 0.5 * 753.5 + late_ns / 1'327'104.0) << line;
  EXPECT_EQ(pos, 1u);  // one position packet per second, the first at the start
  ASSERT_GT(rx.size(), 2u);
  EXPECT_NEAR(static_cast<double>(rx.back() - rx.front()) / static_cast<double>(rx.size() - 1), 1'327'104.0,
              30'000.0 + late_ns / static_cast<double>(rx.size() - 1)) << line;
}

}  // namespace
}  // namespace sensor_rig::lidar::mock
