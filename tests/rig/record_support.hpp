#pragma once
// For the `rig record` / `rig play` tests: the real `rig` in a child process (stdout and stderr to
// files), and known publishers in the test's own participant whose every sample is kept as ground
// truth (stamp, FNV-1a of the payload, source timestamp).
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "rig_process.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"
#include "sensor_rig/dds/types.hpp"
#include "test_data.hpp"
#include "wait_bounds.hpp"

extern char** environ;

namespace sensor_rig::test {

inline std::string read_file(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline std::uint32_t fnv1a_bytes(const void* p, std::size_t n) {
  std::uint32_t h = 0x811c9dc5u;
  const auto* b = static_cast<const unsigned char*>(p);
  for (std::size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 0x01000193u;
  return h;
}

// The real `rig` as a child; SIGKILL in the destructor if still running.
class RigChild {
 public:
  RigChild(const std::vector<std::string>& args, const std::string& out, const std::string& err) : out_(out), err_(err) {
    std::vector<std::string> full{std::getenv("RIG_BIN") != nullptr ? std::getenv("RIG_BIN") : RIG_DEFAULT_BIN};
    full.insert(full.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : full) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addopen(&fa, STDERR_FILENO, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (::posix_spawn(&pid_, argv[0], &fa, nullptr, argv.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&fa);
  }
  ~RigChild() {
    if (pid_ > 0) signal_and_wait(SIGKILL, 5000);
  }
  [[nodiscard]] bool started() const { return pid_ > 0; }
  // Sends `sig` and waits up to `ms`; the exit code, 128+signal when signalled, -1 on timeout.
  int signal_and_wait(int sig, int ms) {
    if (pid_ <= 0) return -1;
    ::kill(pid_, sig);
    return wait(ms);
  }
  // The exit code as wait() gives it once the child has exited; -1 while it runs (never kills it).
  int poll() {
    if (pid_ <= 0) return exited_;
    int st = 0;
    if (::waitpid(pid_, &st, WNOHANG) == 0) return -1;
    pid_ = -1;
    exited_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    return exited_;
  }
  // Waits up to `ms` for the exit; SIGKILL after that (returns -1).
  int wait(int ms) {
    if (pid_ <= 0) return -1;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
    int st = 0;
    while (::waitpid(pid_, &st, WNOHANG) == 0) {
      if (std::chrono::steady_clock::now() > deadline) {
        ::kill(pid_, SIGKILL);
        ::waitpid(pid_, &st, 0);
        pid_ = -1;
        return -1;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    pid_ = -1;
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  }
  [[nodiscard]] std::string out() const { return read_file(out_); }
  [[nodiscard]] std::string err() const { return read_file(err_); }
  // The last line of stdout as JSON (the summary), discarded when absent.
  [[nodiscard]] nlohmann::json summary() const {
    std::string text = out(), last;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);)
      if (!line.empty()) last = line;
    return nlohmann::json::parse(last, nullptr, false);
  }

 private:
  pid_t pid_ = -1;
  int exited_ = -1;
  std::string out_, err_;
};

struct Truth {
  std::int64_t stamp_ns = 0;
  std::uint32_t fnv = 0;
  std::int64_t publish_ns = 0;
  std::uint32_t width = 0;
};

// Known publishers: a cloud, an image, a compressed image, camera info, /diagnostics and /rig/stamps.
class KnownPublishers {
 public:
  KnownPublishers(const dds::Participant& p, const std::string& prefix)
      : prefix_(prefix), q_(qos()), cloud_t_(p, prefix + "/points", q_), cloud_(p, cloud_t_, q_),
        image_t_(p, prefix + "/image_raw", q_), image_(p, image_t_, q_),
        comp_t_(p, prefix + "/image_raw/compressed", best_effort()), comp_(p, comp_t_, best_effort()),
        info_t_(p, prefix + "/camera_info", q_), info_(p, info_t_, q_), diag_t_(p, "/diagnostics", q_),
        diag_(p, diag_t_, q_), stamps_(p) {}

  static dds::QosSpec qos() {
    dds::QosSpec q;
    q.depth = 64;
    q.max_blocking_ms = 1000;
    return q;
  }
  static dds::QosSpec best_effort() {
    dds::QosSpec q = qos();
    q.reliability = dds::QosSpec::Reliability::kBestEffort;
    return q;
  }
  std::vector<std::string> topics() const {
    return {prefix_ + "/points", prefix_ + "/image_raw", prefix_ + "/image_raw/compressed", prefix_ + "/camera_info",
            "/diagnostics", "/rig/stamps"};
  }
  bool wait_for_readers(std::uint32_t n) {
    return cloud_.wait_for_readers(n, kDiscoveryMs) && image_.wait_for_readers(n, kDiscoveryMs) &&
           comp_.wait_for_readers(n, kDiscoveryMs) && info_.wait_for_readers(n, kDiscoveryMs) &&
           diag_.wait_for_readers(n, kDiscoveryMs);
  }

  bool wait_for_points_reader(std::uint32_t n) { return cloud_.wait_for_readers(n, kDiscoveryMs); }

  // One round: a sample on every topic; `cloud_points` sets the cloud's size.
  void publish(int i, std::uint32_t cloud_points = 100) {
    const Nanos stamp = 1'700'000'000'000'000'000 + static_cast<Nanos>(i) * 100'000'000;
    const Nanos pub = vehicle_now_ns();
    char frame[] = "test_frame";
    std::vector<std::uint8_t> cloud_data(static_cast<std::size_t>(cloud_points + static_cast<std::uint32_t>(i)) * 16);
    for (std::size_t k = 0; k < cloud_data.size(); ++k) cloud_data[k] = static_cast<std::uint8_t>(k * 13 + static_cast<std::size_t>(i) * 7);
    msg::PointCloud2 pc{};
    pc.header.stamp = msg::to_time(stamp);
    pc.header.frame_id = frame;
    pc.height = 1;
    pc.width = cloud_points + static_cast<std::uint32_t>(i);
    pc.point_step = 16;
    pc.row_step = pc.width * 16;
    pc.data = {static_cast<std::uint32_t>(cloud_data.size()), static_cast<std::uint32_t>(cloud_data.size()), cloud_data.data(), false};
    EXPECT_TRUE(cloud_.write(pc, pub).ok());
    truth[prefix_ + "/points"].push_back({stamp, fnv1a_bytes(cloud_data.data(), cloud_data.size()), pub, pc.width});

    std::vector<std::uint8_t> pixels(64 * 48 * 3);
    for (std::size_t k = 0; k < pixels.size(); ++k) pixels[k] = static_cast<std::uint8_t>(k ^ static_cast<std::size_t>(i));
    char enc[] = "rgb8";
    msg::Image img{};
    img.header.stamp = msg::to_time(stamp + 1);
    img.header.frame_id = frame;
    img.width = 64;
    img.height = 48;
    img.encoding = enc;
    img.step = 64 * 3;
    img.data = {static_cast<std::uint32_t>(pixels.size()), static_cast<std::uint32_t>(pixels.size()), pixels.data(), false};
    EXPECT_TRUE(image_.write(img, pub + 1).ok());
    truth[prefix_ + "/image_raw"].push_back({stamp + 1, fnv1a_bytes(pixels.data(), pixels.size()), pub + 1, 64});

    std::vector<std::uint8_t> jpeg(500 + static_cast<std::size_t>(i));
    for (std::size_t k = 0; k < jpeg.size(); ++k) jpeg[k] = static_cast<std::uint8_t>(k * 3 + static_cast<std::size_t>(i));
    char fmt[] = "jpeg";
    msg::CompressedImage ci{};
    ci.header.stamp = msg::to_time(stamp + 2);
    ci.header.frame_id = frame;
    ci.format = fmt;
    ci.data = {static_cast<std::uint32_t>(jpeg.size()), static_cast<std::uint32_t>(jpeg.size()), jpeg.data(), false};
    EXPECT_TRUE(comp_.write(ci, pub + 2).ok());
    truth[prefix_ + "/image_raw/compressed"].push_back({stamp + 2, fnv1a_bytes(jpeg.data(), jpeg.size()), pub + 2, 0});

    char model[] = "plumb_bob";
    double d[5] = {0.1, 0.01, 0, 0, static_cast<double>(i)};
    msg::CameraInfo info{};
    info.header.stamp = msg::to_time(stamp + 3);
    info.header.frame_id = frame;
    info.width = 64;
    info.height = 48;
    info.distortion_model = model;
    info.d = {5, 5, d, false};
    for (int k = 0; k < 9; ++k) info.k[k] = k + i;
    EXPECT_TRUE(info_.write(info, pub + 3).ok());
    truth[prefix_ + "/camera_info"].push_back({stamp + 3, 0, pub + 3, 64});

    char name[] = "test: node", message[] = "ok", hw[] = "hw", key[] = "k", value[] = "v";
    msg::KeyValue kv{key, value};
    msg::DiagnosticStatus st{};
    st.level = 1;
    st.name = name;
    st.message = message;
    st.hardware_id = hw;
    st.values = {1, 1, &kv, false};
    msg::DiagnosticArray da{};
    da.header.stamp = msg::to_time(stamp + 4);
    da.status = {1, 1, &st, false};
    EXPECT_TRUE(diag_.write(da, pub + 4).ok());
    truth["/diagnostics"].push_back({stamp + 4, 0, pub + 4, 0});

    dds::SampleStamps s;
    s.acquisition_ns = stamp;
    s.publish_ns = pub;
    stamps_.write(prefix_ + "/points", pc.header.stamp, "test_frame", static_cast<std::uint64_t>(i), s);
    truth["/rig/stamps"].push_back({stamp, 0, 0, 0});
  }

  std::map<std::string, std::vector<Truth>> truth;

 private:
  std::string prefix_;
  dds::QosSpec q_;
  dds::Topic<msg::PointCloud2> cloud_t_;
  dds::Writer<msg::PointCloud2> cloud_;
  dds::Topic<msg::Image> image_t_;
  dds::Writer<msg::Image> image_;
  dds::Topic<msg::CompressedImage> comp_t_;
  dds::Writer<msg::CompressedImage> comp_;
  dds::Topic<msg::CameraInfo> info_t_;
  dds::Writer<msg::CameraInfo> info_;
  dds::Topic<msg::DiagnosticArray> diag_t_;
  dds::Writer<msg::DiagnosticArray> diag_;
  dds::StampsWriter stamps_;
};

// tests/js/mcap_dump.mjs over `file` (@mcap/core + @foxglove/rosmsg2-serialization).
inline nlohmann::json mcap_dump(const std::string& file) {
  const auto script = source_dir() / "tests/js/mcap_dump.mjs";
  const auto [rc, out] = run("node " + script.string() + " " + file + " 2>&1");
  auto j = nlohmann::json::parse(out, nullptr, false);
  if (rc != 0 || j.is_discarded()) return nlohmann::json{{"error", "exit " + std::to_string(rc) + ": " + out}};
  return j;
}

}  // namespace sensor_rig::test
