// Rotating pcap recorder: what it writes is a capture libpcap reads back (payloads, ns record
// times, addresses, or the captured IPv4/UDP headers as they came) that decodes to the same scans;
// rotation by size and by time with a bounded file count; errors (unwritable directory, disk full
// via RLIMIT_FSIZE in a child) are counted, the caller never stops, and every file left behind ends
// at a whole record. The writer thread: its queue keeps order across the ring's end, close() writes
// the whole tail, and a blocked writer makes pushes fail fast and counted, never wait.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <future>
#include <mutex>
#include <thread>
#include <fstream>
#include <iterator>
#include <vector>

#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "sensor_rig/lidar/pcap_reader.hpp"
#include "sensor_rig/lidar/pcap_recorder.hpp"
#include "sensor_rig/lidar/record_queue.hpp"
#include "sensor_rig/lidar/recorder_thread.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"
#include "sensor_rig/lidar/udp_frame.hpp"

namespace sensor_rig::lidar {
namespace {

namespace fs = std::filesystem;

struct TempDir {
  fs::path path;
  TempDir() {
    char tmpl[] = "/tmp/rig-rec-XXXXXX";
    path = ::mkdtemp(tmpl);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

struct Sent {
  std::vector<std::byte> bytes;
  Nanos rx_ns;
};

// `n` packets of a synthetic VLP-16 (position packets included), rx 1 µs after their time.
std::vector<Sent> vlp16_stream(std::size_t n) {
  mock::SyntheticOptions o;
  o.model = "VLP-16";
  o.start_ns = 1'700'000'000'000'000'000LL;
  auto s = mock::make_synthetic_sensor(o, mock::Scene::standard());
  std::vector<Sent> out;
  while (out.size() < n) {
    const auto p = s->next();
    out.push_back({{p.bytes.begin(), p.bytes.end()}, p.time_ns + 1000});
  }
  return out;
}

const UdpAddressing kAddr{0x7F000001, 40000, 0x7F000001, 2368};

std::vector<fs::path> pcaps(const fs::path& dir) {
  std::vector<fs::path> v;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".pcap") v.push_back(e.path());
  std::sort(v.begin(), v.end());
  return v;
}

std::vector<Sent> read_all(const std::vector<fs::path>& files, std::vector<std::string>* errors = nullptr) {
  std::vector<Sent> v;
  for (const auto& f : files) {
    PcapReader r(f.string());
    while (auto rec = r.next()) v.push_back({{rec->packet.data.begin(), rec->packet.data.end()}, rec->packet.rx_ns});
    if (errors != nullptr) errors->push_back(r.error());
  }
  return v;
}

// Scans (points, stamp, packets) of a packet list decoded as the CLI does (stamp = rx time).
std::vector<std::pair<std::size_t, std::vector<std::byte>>> scans_of(const std::vector<Sent>& pkts) {
  DecoderOptions o;
  o.model = "VLP-16";
  auto dec = make_decoder(o);
  std::vector<std::pair<std::size_t, std::vector<std::byte>>> out;
  for (const auto& p : pkts) {
    const PacketView v{p.bytes, p.rx_ns, static_cast<std::uint16_t>(p.bytes.size() == 512 ? 8308 : 2368)};
    if (!dec->is_data_packet(v)) continue;
    if (auto s = dec->push(v, p.rx_ns)) {
      const auto* b = reinterpret_cast<const std::byte*>(s->points.data());
      out.emplace_back(s->packets, std::vector<std::byte>(b, b + s->points.size() * sizeof(PointXYZIRT)));
    }
  }
  return out;
}

TEST(PcapRecorder, RoundTripIsTheSameCaptureAndTheSameScans) {
  TempDir d;
  const auto stream = vlp16_stream(3 * 760);  // > 2 turns at 600 rpm
  PcapRecorderConfig c;
  c.directory = (d.path / "rec").string();  // created on the first packet
  c.prefix = "front";
  PcapRecorder rec(c);
  for (const auto& p : stream) ASSERT_TRUE(rec.write(p.bytes, p.rx_ns, kAddr));
  rec.close();
  EXPECT_EQ(rec.stats().packets, stream.size());
  EXPECT_EQ(rec.stats().errors, 0u);
  EXPECT_EQ(rec.stats().files_opened, 1u);
  const auto files = pcaps(c.directory);
  ASSERT_EQ(files.size(), 1u);
  EXPECT_EQ(files[0].filename().string().rfind("front_000000_2023", 0), 0u) << files[0];
  PcapReader r(files[0].string());
  EXPECT_EQ(r.linktype(), 1);
  std::size_t i = 0;
  while (auto x = r.next()) {
    ASSERT_LT(i, stream.size());
    EXPECT_EQ(x->packet.rx_ns, stream[i].rx_ns);  // nanosecond record times
    EXPECT_EQ(x->packet.dst_port, 2368);
    EXPECT_EQ(x->src_port, 40000);
    EXPECT_EQ(x->src_ip, 0x7F000001u);
    ASSERT_TRUE(std::equal(x->packet.data.begin(), x->packet.data.end(), stream[i].bytes.begin(), stream[i].bytes.end()))
        << i;
    ++i;
  }
  EXPECT_EQ(r.error(), "");
  EXPECT_EQ(i, stream.size());
  EXPECT_EQ(r.stats().fragments + r.stats().not_udp + r.stats().bad + r.stats().truncated, 0u);
  const auto a = scans_of(stream), b = scans_of(read_all(files));
  ASSERT_GE(a.size(), 2u);
  EXPECT_EQ(a, b);
}

// The packet ring's datagrams keep their own IPv4/UDP headers (options, TTL, ID, TOS, checksum):
// copied into the record as they came; a payload cut short keeps the headers' original length.
TEST(PcapRecorder, CapturedHeadersAreKeptAsTheyCame) {
  TempDir d;
  const auto stream = vlp16_stream(2);
  // IPv4 with 4 bytes of options (IHL 6): TOS 0x28, ID 0x1234, TTL 3, 10.0.0.5:2368 -> 10.0.0.9:2368.
  std::vector<std::byte> h(24 + 8);
  const std::size_t total = h.size() + stream[0].bytes.size();
  const std::vector<int> ip{0x46, 0x28, static_cast<int>(total >> 8), static_cast<int>(total & 0xff), 0x12, 0x34, 0x40, 0,
                            3, 17, 0, 0, 10, 0, 0, 5, 10, 0, 0, 9, 0x94, 0x04, 0, 0};
  for (std::size_t i = 0; i < ip.size(); ++i) h[i] = static_cast<std::byte>(ip[i]);
  const std::size_t udp_len = 8 + stream[0].bytes.size();
  const std::vector<int> udp{0x09, 0x40, 0x09, 0x40, static_cast<int>(udp_len >> 8), static_cast<int>(udp_len & 0xff), 0xab, 0xcd};
  for (std::size_t i = 0; i < udp.size(); ++i) h[24 + i] = static_cast<std::byte>(udp[i]);
  const auto sum = ipv4_header_checksum(std::span(h).first(24));
  h[10] = static_cast<std::byte>(sum >> 8);
  h[11] = static_cast<std::byte>(sum & 0xff);
  PcapRecorderConfig c;
  c.directory = d.path.string();
  PcapRecorder rec(c);
  ASSERT_TRUE(rec.write(stream[0].bytes, stream[0].rx_ns, DatagramHeaders{kAddr, h}));
  const auto cut = std::span(stream[0].bytes).first(100);  // a slot too small for the datagram
  ASSERT_TRUE(rec.write(cut, stream[0].rx_ns + 1, DatagramHeaders{kAddr, h}));
  EXPECT_FALSE(rec.write(stream[0].bytes, 0, DatagramHeaders{kAddr, std::span(h).first(20)})) << "no UDP header";
  EXPECT_EQ(rec.stats().dropped, 1u);
  rec.close();
  const auto files = pcaps(d.path);
  ASSERT_EQ(files.size(), 1u);
  std::ifstream in(files[0], std::ios::binary);
  const std::vector<char> b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_EQ(b.size(), 24 + 2 * (16 + 14 + h.size()) + stream[0].bytes.size() + cut.size());
  EXPECT_TRUE(std::equal(h.begin(), h.end(), reinterpret_cast<const std::byte*>(b.data() + 24 + 16 + 14)));
  PcapReader r(files[0].string());
  auto x = r.next();
  ASSERT_TRUE(x);
  EXPECT_EQ(x->src_ip, 0x0A000005u);
  EXPECT_EQ(x->dst_ip, 0x0A000009u);
  EXPECT_EQ(x->packet.dst_port, 2368);
  EXPECT_EQ(x->packet.rx_ns, stream[0].rx_ns);
  EXPECT_TRUE(std::equal(x->packet.data.begin(), x->packet.data.end(), stream[0].bytes.begin(), stream[0].bytes.end()));
  EXPECT_FALSE(r.next()) << "the cut record is a truncated capture, not a datagram";
  EXPECT_EQ(r.stats().truncated, 1u);
}

TEST(PcapRecorder, RotatesBySizeAndTimeAndKeepsMaxFiles) {
  TempDir d;
  const auto stream = vlp16_stream(1000);
  PcapRecorderConfig c;
  c.directory = d.path.string();
  c.prefix = "left";
  c.max_file_bytes = 64 * 1024;  // ~50 packets a file
  c.max_file_ns = 0;
  c.max_files = 3;
  {
    PcapRecorder rec(c);
    for (const auto& p : stream) ASSERT_TRUE(rec.write(p.bytes, p.rx_ns, kAddr));
    EXPECT_GT(rec.stats().files_opened, 10u);
    EXPECT_EQ(rec.stats().files_deleted, rec.stats().files_opened - 3);
  }
  auto files = pcaps(d.path);
  ASSERT_EQ(files.size(), 3u);
  for (const auto& f : files) EXPECT_LE(fs::file_size(f), c.max_file_bytes);
  std::vector<std::string> errors;
  const auto tail = read_all(files, &errors);
  for (const auto& e : errors) EXPECT_EQ(e, "");
  ASSERT_FALSE(tail.empty());
  // The kept files are the stream's last packets, in order, nothing missing between them.
  const std::size_t first = stream.size() - tail.size();
  for (std::size_t i = 0; i < tail.size(); ++i) ASSERT_EQ(tail[i].bytes, stream[first + i].bytes) << i;

  // A second run with the same prefix continues the numbering and counts the old files.
  {
    PcapRecorder rec(c);
    ASSERT_TRUE(rec.write(stream[0].bytes, stream[0].rx_ns, kAddr));
    EXPECT_EQ(rec.stats().files_deleted, 1u);
  }
  files = pcaps(d.path);
  ASSERT_EQ(files.size(), 3u);

  // By time: 1 s of packets, a file per 100 ms.
  TempDir d2;
  c.directory = d2.path.string();
  c.max_file_bytes = 256ULL << 20;
  c.max_file_ns = 100'000'000;
  c.max_files = 100;
  PcapRecorder rec(c);
  const auto second = vlp16_stream(755);  // 1 s of a VLP-16 + its position packet
  for (const auto& p : second) ASSERT_TRUE(rec.write(p.bytes, p.rx_ns, kAddr));
  EXPECT_EQ(rec.stats().files_opened, 10u);
}

TEST(PcapRecorder, UnwritableDirectoryIsCountedAndRetried) {
  TempDir d;
  std::ofstream(d.path / "a_file") << "x";
  PcapRecorderConfig c;
  c.directory = (d.path / "a_file" / "sub").string();  // ENOTDIR even for root
  c.retry_ns = 1'000'000'000;
  PcapRecorder rec(c);
  const auto stream = vlp16_stream(20);
  Nanos t = 1'000'000'000;
  for (const auto& p : stream) EXPECT_FALSE(rec.write(p.bytes, t += 1'000'000, kAddr));
  EXPECT_EQ(rec.stats().errors, 1u);  // one failure, then the back-off drops without retrying
  EXPECT_EQ(rec.stats().dropped, 20u);
  EXPECT_NE(rec.last_error().find("cannot create"), std::string::npos) << rec.last_error();
  EXPECT_FALSE(rec.write(stream[0].bytes, t + 2'000'000'000, kAddr));  // retried after 1 s: fails again
  EXPECT_EQ(rec.stats().errors, 2u);
  EXPECT_EQ(rec.stats().packets, 0u);
  EXPECT_THROW(PcapRecorder(PcapRecorderConfig{}), std::invalid_argument);
  PcapRecorderConfig z = c;
  z.max_files = 0;
  EXPECT_THROW(PcapRecorder{z}, std::invalid_argument);
}

// Disk full: a child process with a 100 kB file size limit (a write past it fails, short or with
// EFBIG, as on a full disk). It keeps writing; each file fills, is cut at its last whole record,
// packets are dropped for the back-off, a new file is opened. The parent checks the counts and the
// files on disk.
TEST(PcapRecorder, DiskFullIsCountedAndTheFileStaysReadable) {
  TempDir d;
  const auto stream = vlp16_stream(300);
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::signal(SIGXFSZ, SIG_IGN);
    rlimit lim{100'000, 100'000};
    ::setrlimit(RLIMIT_FSIZE, &lim);
    PcapRecorderConfig c;
    c.directory = d.path.string();
    c.retry_ns = 10'000'000;
    PcapRecorder rec(c);
    std::uint64_t ok = 0;
    for (const auto& p : stream) ok += rec.write(p.bytes, p.rx_ns, kAddr) ? 1 : 0;
    const std::uint64_t v[4] = {ok, rec.stats().packets, rec.stats().errors, rec.stats().dropped};
    (void)!::write(fds[1], v, sizeof v);
    ::_exit(0);
  }
  ::close(fds[1]);
  std::uint64_t v[4] = {};
  ASSERT_EQ(::read(fds[0], v, sizeof v), static_cast<ssize_t>(sizeof v));
  ::close(fds[0]);
  int st = 0;
  ::waitpid(pid, &st, 0);
  ASSERT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 0);
  EXPECT_EQ(v[0], v[1]);
  EXPECT_GE(v[2], 2u);    // the full file, then (after each back-off) a new file that fills up too
  EXPECT_GT(v[3], 0u);
  EXPECT_EQ(v[1] + v[3], stream.size());
  std::vector<std::string> errors;
  const auto files = pcaps(d.path);
  EXPECT_GE(files.size(), v[2]);  // every file but perhaps the last filled up once
  EXPECT_LE(files.size(), v[2] + 1);
  for (const auto& f : files) EXPECT_LE(fs::file_size(f), 100'000u);
  const auto back = read_all(files, &errors);
  for (const auto& e : errors) EXPECT_EQ(e, "") << "a file ends in a partial record";
  EXPECT_EQ(back.size(), v[1]);
}


// Records of varied sizes through a small queue, many times round its end: each comes out whole,
// in order, with its time and headers; a record larger than the free room is refused and counted.
TEST(RecordQueue, KeepsOrderAcrossTheRingsEnd) {
  RecordQueue q(2 * (kMaxRecordedPayload + 200));
  const std::vector<std::byte> hdr(28, std::byte{0x45});
  std::uint64_t pushed = 0, popped = 0;
  auto payload = [](std::uint64_t id) {
    std::vector<std::byte> p(1 + (id * 7919) % 30000);
    for (std::size_t i = 0; i < p.size(); ++i) p[i] = static_cast<std::byte>((id + i) & 0xff);
    return p;
  };
  for (int round = 0; round < 200; ++round) {
    for (int k = 0; k < 8; ++k) {
      const auto p = payload(pushed);
      const DatagramHeaders h{UdpAddressing{1, 2, 3, static_cast<std::uint16_t>(pushed)}, std::span(hdr).first(pushed % 2 == 0 ? 28 : 0)};
      if (q.push(p, static_cast<Nanos>(pushed), h)) ++pushed;
    }
    q.drain([&](std::span<const std::byte> p, Nanos rx, const DatagramHeaders& h) {
      EXPECT_EQ(rx, static_cast<Nanos>(popped));
      EXPECT_EQ(h.addressing.dst_port, static_cast<std::uint16_t>(popped));
      EXPECT_EQ(h.captured.size(), popped % 2 == 0 ? 28u : 0u);
      const auto want = payload(popped);
      EXPECT_TRUE(std::equal(p.begin(), p.end(), want.begin(), want.end())) << popped;
      ++popped;
    });
  }
  EXPECT_EQ(popped, pushed);
  EXPECT_GT(pushed, 400u);
  EXPECT_GT(q.dropped(), 0u) << "eight records of up to 30 kB do not always fit";
  EXPECT_THROW(RecordQueue(100000), std::invalid_argument);
}

// No lost tail: the writer would not wake for 10 s, yet close() writes every queued packet.
TEST(RecorderThread, CloseWritesEveryQueuedPacket) {
  TempDir d;
  const auto stream = vlp16_stream(3 * 760);
  PcapRecorderConfig c;
  c.directory = d.path.string();
  RecorderThread rec(std::make_unique<PcapRecorder>(c), 16 << 20, 10'000'000'000);
  for (const auto& p : stream) ASSERT_TRUE(rec.push(p.bytes, p.rx_ns, DatagramHeaders{kAddr, {}}));
  rec.close();
  const auto st = rec.status();
  EXPECT_EQ(st.sink.stats.packets, stream.size());
  EXPECT_EQ(st.dropped(), 0u);
  const auto back = read_all(pcaps(d.path));
  ASSERT_EQ(back.size(), stream.size());
  for (std::size_t i = 0; i < back.size(); ++i) {
    ASSERT_EQ(back[i].bytes, stream[i].bytes) << i;
    ASSERT_EQ(back[i].rx_ns, stream[i].rx_ns) << i;
  }
}

// A sink stuck in its first write (a stalled disk) until released; remembers what it was given.
class StalledSink final : public RecordSink {
 public:
  bool write(std::span<const std::byte>, Nanos rx_ns, const DatagramHeaders&) noexcept override {
    std::unique_lock lock(mutex_);
    cv_.wait(lock, [this] { return released_; });
    got_.push_back(rx_ns);
    return true;
  }
  void close() noexcept override {}
  [[nodiscard]] RecordSinkStatus status() const override {
    std::lock_guard lock(mutex_);
    RecordSinkStatus s;
    s.stats.packets = got_.size();
    return s;
  }
  void release() {
    std::lock_guard lock(mutex_);
    released_ = true;
    cv_.notify_all();
  }
  std::vector<Nanos> got() const {
    std::lock_guard lock(mutex_);
    return got_;
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  bool released_ = false;
  std::vector<Nanos> got_;
};

// The writer blocked: the receive thread's pushes fill the queue, then fail at once and are
// counted; none waits. Released, the writer writes exactly the accepted packets, in order.
TEST(RecorderThread, StalledWriterDropsAndCountsWithoutBlockingTheReceiveThread) {
  auto sink = std::make_unique<StalledSink>();
  StalledSink* stalled = sink.get();
  constexpr std::size_t kQueue = 256 << 10;
  RecorderThread rec(std::move(sink), kQueue, 1'000'000);
  const std::vector<std::byte> packet(1206, std::byte{0x11});
  constexpr std::size_t kPushed = 2000;
  auto receive_thread = std::async(std::launch::async, [&] {
    std::vector<Nanos> accepted;
    for (std::size_t i = 0; i < kPushed; ++i) {
      if (rec.push(packet, static_cast<Nanos>(i), DatagramHeaders{kAddr, {}})) accepted.push_back(static_cast<Nanos>(i));
      if (i == 0) std::this_thread::sleep_for(std::chrono::milliseconds(20));  // the writer takes #0 and stalls
    }
    return accepted;
  });
  ASSERT_EQ(receive_thread.wait_for(std::chrono::seconds(5)), std::future_status::ready)
      << "a push waited for the stalled writer";
  const auto accepted = receive_thread.get();
  EXPECT_GT(accepted.size(), 100u);                   // ~200 records of 1.3 kB fit in 256 KiB
  EXPECT_LT(accepted.size(), kPushed / 2);
  EXPECT_EQ(rec.status().queue_dropped, kPushed - accepted.size());
  EXPECT_EQ(rec.status().dropped(), kPushed - accepted.size());
  stalled->release();
  rec.close();
  EXPECT_EQ(stalled->got(), accepted);
  EXPECT_EQ(rec.status().sink.stats.packets, accepted.size());
}

}  // namespace
}  // namespace sensor_rig::lidar
