// Rotating pcap recorder: what it writes is a capture libpcap reads back (payloads, ns record
// times, addresses) that decodes to the same scans; rotation by size and by time with a bounded
// file count; errors (unwritable directory, disk full via RLIMIT_FSIZE in a child) are counted, the
// caller never stops, and every file left behind ends at a whole record.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <vector>

#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "sensor_rig/lidar/pcap_reader.hpp"
#include "sensor_rig/lidar/pcap_recorder.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"

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

}  // namespace
}  // namespace sensor_rig::lidar
