#pragma once
// Running the real `rig` binary from a test ($RIG_BIN, set by ctest): exit code, stdout, stderr.
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace sensor_rig::test {

struct CliRun {
  int code = -1;  // exit code; -1 when it could not run or died by a signal
  std::string out;
  std::string err;
};

inline std::string rig_bin_or_empty() {
  const char* b = std::getenv("RIG_BIN");
  return b != nullptr ? b : "";
}

// Runs `$RIG_BIN ARGS` through the shell (ARGS may hold redirections and quotes).
inline CliRun run_rig(const std::string& args) {
  static int counter = 0;
  const auto err = std::filesystem::temp_directory_path() /
                   ("rig_cli_err_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  const std::string cmd = rig_bin_or_empty() + " " + args + " 2>" + err.string();
  CliRun r;
  FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) return r;
  char buf[4096];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int st = ::pclose(p);
  r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  std::ifstream in(err);
  std::ostringstream s;
  s << in.rdbuf();
  r.err = s.str();
  std::filesystem::remove(err);
  return r;
}

}  // namespace sensor_rig::test
