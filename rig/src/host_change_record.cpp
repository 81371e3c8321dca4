#include "host_change_record.hpp"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace sensor_rig::rig {
namespace {

namespace fs = std::filesystem;

fs::path state_dir() {
  const char* dir = std::getenv("RIG_STATE_DIR");
  return dir != nullptr && *dir != '\0' ? fs::path(dir) : fs::path("/run/sensor-rig");
}

std::atomic<int> g_counter{0};

void remove_dir_if_empty() noexcept {
  std::error_code ec;
  fs::remove(state_dir(), ec);  // fails, harmlessly, while it holds anything else
}

}  // namespace

bool process_running(long pid) {
  if (pid <= 0 || (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH)) return false;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return true;  // no /proc: kill() said it exists
  const auto paren = line.rfind(')');
  return paren == std::string::npos || paren + 2 >= line.size() || line[paren + 2] != 'Z';
}

HostChangeRecord::HostChangeRecord(const std::string& kind, const std::string& content) {
  std::error_code ec;
  fs::create_directories(state_dir(), ec);
  path_ = (state_dir() / (kind + "-" + std::to_string(::getpid()) + "-" + std::to_string(g_counter++))).string();
  std::ofstream out(path_, std::ios::trunc);
  out << content;
  out.flush();
  if (!out) {
    out.close();
    remove();
    throw std::runtime_error("cannot record the host change in " + path_);
  }
}

void HostChangeRecord::remove() noexcept {
  std::error_code ec;
  fs::remove(path_, ec);
  remove_dir_if_empty();
}

std::vector<HostChangeRecord::Orphan> HostChangeRecord::orphans(const std::string& kind) {
  std::vector<Orphan> out;
  std::error_code ec;
  const std::string prefix = kind + "-";
  for (const auto& e : fs::directory_iterator(state_dir(), ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind(prefix, 0) != 0) continue;
    const long pid = std::strtol(name.c_str() + prefix.size(), nullptr, 10);
    if (pid <= 0 || process_running(pid)) continue;  // its owner runs
    std::ostringstream content;
    content << std::ifstream(e.path()).rdbuf();
    out.push_back({e.path(), pid, content.str()});
  }
  return out;
}

void HostChangeRecord::remove_orphan(const Orphan& o) noexcept {
  std::error_code ec;
  fs::remove(o.path, ec);
  remove_dir_if_empty();
}

}  // namespace sensor_rig::rig
