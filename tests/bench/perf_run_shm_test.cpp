// Short real runs of `rig perf run --transport shm`: the runner starts and stops its own RouDi
// (ctest RESOURCE_LOCK keeps these from running in parallel with another RouDi user), writers loan
// chunks only for the fixed-size types, and the runner leaves processes it did not start alone.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "perf_run_util.hpp"

namespace sensor_rig::bench::perf::test {
namespace {
namespace fs = std::filesystem;

bool roudi_available() { return fs::exists("/usr/bin/iox-roudi"); }

// topology, size, message, domain, reader (pointcloud2: copy | view)
class PerfRunShm : public ::testing::TestWithParam<std::tuple<int, const char*, const char*, int, const char*>> {};

TEST_P(PerfRunShm, CountsAddUpLoansAndRoudiIsCleanedUp) {
  if (rig_bin().empty()) GTEST_SKIP() << "RIG_BIN not set or not built";
  if (!roudi_available()) GTEST_SKIP() << "iox-roudi (package iceoryx) not installed";
  const auto [topology, size, message, domain, reader] = GetParam();
  const auto out = fresh_dir("shm_t" + std::to_string(topology) + "_" + message + "_" + reader);
  const auto r = rig_perf_run("run --topology " + std::to_string(topology) + " --nodes " + (topology == 1 ? "4" : "3") + " --size " + size +
                                  " --rate 20 --duration 1 --transport shm --message " + message + " --domain " +
                                  std::to_string(domain) + " --reader " + reader,
                              out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  check_invariants(r.summary, true);
  check_raw_csvs(r, true);
  EXPECT_EQ(r.summary["transport"], "shm");
  EXPECT_EQ(r.summary["message"], message);
  ASSERT_TRUE(r.summary.contains("roudi"));
  // Loans: only the fixed-size types are loaned (written and read in the chunk); Cyclone 0.10
  // serialises sequence types (seq, PointCloud2) into the chunk instead.
  const auto& loans = r.summary["loans"];
  const auto sent = r.summary["sent"].get<std::uint64_t>();
  const auto received = r.summary["received"].get<std::uint64_t>();
  ASSERT_GT(sent, 0u);
  EXPECT_EQ(loans["nodes_reporting"], r.summary["nodes"]);
  const bool fixed = std::string(message) == "fixed";
  // --reader view: the serialized PointCloud2 is read where it lies, in the chunk.
  const bool in_chunk = fixed || std::string(reader) == "view";
  EXPECT_EQ(loans["loaned_writes"].get<std::uint64_t>(), fixed ? sent : 0u) << loans.dump();
  EXPECT_EQ(loans["copied_writes"].get<std::uint64_t>(), fixed ? 0u : sent) << loans.dump();
  EXPECT_EQ(loans["zero_copy_takes"].get<std::uint64_t>(), in_chunk ? received : 0u) << loans.dump();
  EXPECT_EQ(loans["copied_takes"].get<std::uint64_t>(), in_chunk ? 0u : received) << loans.dump();
  EXPECT_EQ(loans["writers_used_loans"].get<bool>(), fixed);
  EXPECT_EQ(loans["readers_took_zero_copy"].get<bool>(), in_chunk);
  if (!fixed) {
    EXPECT_NE(loans["expected_path"].get<std::string>().find("cannot loan"), std::string::npos);
  }
  for (const auto& p : r.summary["processes"]) {
    ASSERT_TRUE(p.contains("data_path")) << p.dump();
    if (p["role"] == "pub") {
      EXPECT_EQ(p["data_path"]["loan_available"].get<bool>(), fixed);
    }
  }
  if (!r.summary["roudi"]["external"].get<bool>()) {
    // Ours: stopped again, and its shared memory and lock are gone; its CPU and RSS recorded.
    EXPECT_FALSE(fs::exists("/dev/shm/iceoryx_mgmt"));
    EXPECT_FALSE(fs::exists("/tmp/iox-unique-roudi.lock"));
    EXPECT_GT(r.summary["roudi"]["max_rss_kb"].get<long>(), 0);
    EXPECT_GE(r.summary["roudi"]["cpu_s"].get<double>(), 0.0);
    EXPECT_GT(r.summary["roudi"]["lifetime_max_rss_kb"].get<long>(), 0);
    EXPECT_GT(r.summary["roudi"]["lifetime_cpu_s"].get<double>(), 0.0);
  }
}

INSTANTIATE_TEST_SUITE_P(Topologies, PerfRunShm,
                         ::testing::Values(std::make_tuple(1, "64kB", "fixed", 191, "copy"),
                                           std::make_tuple(2, "1MB", "fixed", 192, "copy"),
                                           std::make_tuple(3, "16B", "fixed", 193, "copy"),
                                           std::make_tuple(2, "64kB", "seq", 194, "copy"),
                                           std::make_tuple(2, "1MB", "pointcloud2", 195, "copy"),
                                           std::make_tuple(2, "1MB", "pointcloud2", 197, "view")));

// A process the test starts (stdout/stderr to `log`), killed and reaped when the test ends.
class Foreign {
 public:
  Foreign(const std::vector<std::string>& argv, const std::string& log) {
    pid_ = ::fork();
    if (pid_ == 0) {
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      ::setpgid(0, 0);  // not in the test's group either
      std::vector<char*> args;
      for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      ::execv(args[0], args.data());
      ::_exit(127);
    }
  }
  ~Foreign() {
    if (alive()) {
      ::kill(pid_, SIGTERM);
      for (int i = 0; i < 500 && alive(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
      if (alive()) ::kill(pid_, SIGKILL);
    }
    if (!reaped_) ::waitpid(pid_, nullptr, 0);
  }
  Foreign(const Foreign&) = delete;
  Foreign& operator=(const Foreign&) = delete;
  [[nodiscard]] pid_t pid() const { return pid_; }
  bool alive() {
    if (reaped_ || pid_ <= 0) return false;
    if (::waitpid(pid_, nullptr, WNOHANG) == pid_) reaped_ = true;
    return !reaped_;
  }

 private:
  pid_t pid_ = -1;
  bool reaped_ = false;
};

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A RouDi that was already running and an unrelated process both survive a shared-memory run: the
// runner uses that RouDi (and says so) but signals only the nodes it started.
TEST(PerfRunShmForeign, RunnerKillsNothingItDidNotStart) {
  if (rig_bin().empty()) GTEST_SKIP() << "RIG_BIN not set or not built";
  if (!roudi_available()) GTEST_SKIP() << "iox-roudi (package iceoryx) not installed";
  const auto dir = fresh_dir("shm_foreign");
  const auto cfg = dir + "/roudi.toml";
  std::ofstream(cfg) << "[general]\nversion = 1\n\n[[segment]]\n\n[[segment.mempool]]\nsize = 1024\ncount = 500\n\n"
                        "[[segment.mempool]]\nsize = 66560\ncount = 64\n";
  Foreign roudi({"/usr/bin/iox-roudi", "-c", cfg, "-l", "info"}, dir + "/roudi.log");
  for (int i = 0; i < 1000 && slurp(dir + "/roudi.log").find("RouDi is ready for clients") == std::string::npos; ++i) {
    ASSERT_TRUE(roudi.alive()) << slurp(dir + "/roudi.log");
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  Foreign sleeper({"/bin/sleep", "60"}, "/dev/null");
  const auto r = rig_perf_run("run --topology 2 --nodes 3 --size 64kB --rate 20 --duration 1 --transport shm --domain 196",
                              dir + "/run");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  check_invariants(r.summary, true);
  ASSERT_TRUE(r.summary.contains("roudi"));
  EXPECT_TRUE(r.summary["roudi"]["external"].get<bool>());
  EXPECT_EQ(r.summary["roudi"]["pid"].get<int>(), roudi.pid());
  EXPECT_NE(r.summary["warnings"].dump().find("already running RouDi"), std::string::npos);
  EXPECT_TRUE(roudi.alive()) << "the runner stopped a RouDi it did not start";
  EXPECT_TRUE(sleeper.alive()) << "the runner killed an unrelated process";
  EXPECT_TRUE(fs::exists("/dev/shm/iceoryx_mgmt")) << "the runner removed a running RouDi's shared memory";
}

}  // namespace
}  // namespace sensor_rig::bench::perf::test
