// common's ChildProcess with real processes (/bin/sh): pipes, environment, log file, process group,
// exit information, stop with SIGTERM then SIGKILL, and the /proc helpers.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/common/clock.hpp"

namespace sensor_rig {
namespace {

std::vector<std::string> read_lines_until_eof(ChildProcess& c, int timeout_ms) {
  std::vector<std::string> all;
  for (int waited = 0; !c.stdout_eof() && waited < timeout_ms; waited += 5) {
    for (auto& l : c.read_lines()) all.push_back(l);
    ::usleep(5'000);
  }
  return all;
}

TEST(ChildProcess, PipesLinesBothWaysAndPassesTheEnvironment) {
  std::signal(SIGPIPE, SIG_IGN);  // as `rig` does: a write to a child that is gone returns an error
  ChildOptions o;
  o.pipe_stdio = true;
  o.env = {"RIG_CHILD_TEST=42", "HOME=/nowhere"};  // added, and replacing one we have
  ChildProcess c({"/bin/sh", "-c", "read x; echo got $x $RIG_CHILD_TEST $HOME; exit 3"}, o);
  ASSERT_TRUE(c.send_line("hello"));
  const auto lines = read_lines_until_eof(c, 5000);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0], "got hello 42 /nowhere");
  ASSERT_TRUE(c.wait_exit(5000));
  EXPECT_EQ(c.exit_status(), 3);
  EXPECT_TRUE(c.exit_info().exited);
  EXPECT_EQ(c.exit_info().exit_code, 3);
  EXPECT_GT(c.exit_info().max_rss_kb, 0);
  EXPECT_FALSE(c.send_line("late") && c.running());
}

TEST(ChildProcess, LogFileOwnProcessGroupAndStopBySignal) {
  const auto log = std::filesystem::temp_directory_path() / ("child_test_" + std::to_string(::getpid()) + ".log");
  std::filesystem::remove(log);
  ChildOptions o;
  o.log_file = log.string();
  o.process_group = 0;
  // Ignores SIGTERM: stop() must fall back to SIGKILL after the grace period.
  ChildProcess c({"/bin/sh", "-c", "trap '' TERM; echo out; echo err >&2; while true; do sleep 0.05; done"}, o);
  for (int i = 0; i < 200 && ::getpgid(c.pid()) != c.pid(); ++i) ::usleep(5'000);
  EXPECT_EQ(::getpgid(c.pid()), c.pid()) << "a process group of its own";
  ::usleep(100'000);
  const Nanos t0 = monotonic_now_ns();
  EXPECT_EQ(c.stop(300), 128 + SIGKILL);
  EXPECT_GE(monotonic_now_ns() - t0, 300'000'000);
  EXPECT_EQ(c.exit_info().term_signal, SIGKILL);
  EXPECT_FALSE(c.running());
  c.signal(SIGTERM);  // reaped: never signalled again (its PID may be reused)
  std::ifstream in(log);
  std::stringstream s;
  s << in.rdbuf();
  EXPECT_EQ(s.str(), "out\nerr\n");
  std::filesystem::remove(log);
}

TEST(ChildProcess, AProgramThatCannotRunExits127AndUsageIsReadable) {
  ChildProcess missing({"/nonexistent/program"});
  ASSERT_TRUE(missing.wait_exit(5000));
  EXPECT_EQ(missing.exit_status(), 127);
  const auto me = process_usage(::getpid());
  EXPECT_TRUE(me.known);
  EXPECT_GT(me.max_rss_kb, 0);
  EXPECT_FALSE(process_usage(-1).known);
  ChildProcess sleeper({"/bin/sleep", "5"});
  auto listed = [&] {
    const auto found = find_processes("sleep");
    return std::find(found.begin(), found.end(), sleeper.pid()) != found.end();
  };
  for (int i = 0; i < 400 && !listed(); ++i) ::usleep(5'000);  // named "sleep" once it has exec'd
  EXPECT_TRUE(listed());
  EXPECT_EQ(sleeper.stop(2000), 128 + SIGTERM);
  EXPECT_THROW(ChildProcess(std::vector<std::string>{}), std::invalid_argument);
}

// The child is started by clone(CLONE_VM | CLONE_VFORK) in our memory: it must leave with the
// signal state a fork would give it (our handlers gone, what we ignore still ignored, our mask), our
// handlers untouched, and PR_SET_PDEATHSIG set (its parent thread's end stops it).
std::uint64_t status_mask(const std::vector<std::string>& lines, const std::string& field) {
  for (const auto& l : lines)
    if (l.rfind(field + ":", 0) == 0) return std::stoull(l.substr(field.size() + 1), nullptr, 16);
  ADD_FAILURE() << field << " not in the child's /proc status";
  return 0;
}
std::uint64_t bit(int sig) { return std::uint64_t{1} << (sig - 1); }
void on_usr1(int) {}

TEST(ChildProcess, TheChildHasTheSignalStateAForkWouldGiveAndOursIsUntouched) {
  std::signal(SIGPIPE, SIG_IGN);
  struct sigaction ours{};
  ours.sa_handler = on_usr1;
  ASSERT_EQ(::sigaction(SIGUSR1, &ours, nullptr), 0);
  sigset_t usr2, before;
  ::sigemptyset(&usr2);
  ::sigaddset(&usr2, SIGUSR2);
  ::pthread_sigmask(SIG_BLOCK, &usr2, &before);
  ChildOptions o;
  o.pipe_stdio = true;
  ChildProcess c({"/bin/cat", "/proc/self/status"}, o);
  ::pthread_sigmask(SIG_SETMASK, &before, nullptr);
  const auto lines = read_lines_until_eof(c, 5000);
  ASSERT_TRUE(c.wait_exit(5000));
  EXPECT_EQ(c.exit_status(), 0);
  EXPECT_EQ(status_mask(lines, "SigCgt") & bit(SIGUSR1), 0u) << "our handler does not reach the program";
  EXPECT_NE(status_mask(lines, "SigIgn") & bit(SIGPIPE), 0u) << "what we ignore stays ignored, as across fork";
  EXPECT_NE(status_mask(lines, "SigBlk") & bit(SIGUSR2), 0u) << "the caller's mask, as across fork";
  struct sigaction now{};
  ASSERT_EQ(::sigaction(SIGUSR1, nullptr, &now), 0);
  EXPECT_EQ(now.sa_handler, &on_usr1) << "the child reset its own dispositions, not ours";
  std::signal(SIGUSR1, SIG_DFL);
}

TEST(ChildProcess, TheEndOfItsParentThreadStopsTheChild) {
  ChildProcess c;
  std::thread([&c] { c = ChildProcess({"/bin/sleep", "30"}); }).join();
  ASSERT_TRUE(c.wait_exit(5000)) << "PR_SET_PDEATHSIG: SIGTERM when the thread that started it ended";
  EXPECT_EQ(c.exit_status(), 128 + SIGTERM);
}

}  // namespace
}  // namespace sensor_rig
