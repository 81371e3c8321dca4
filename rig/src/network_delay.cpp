#include "network_delay.hpp"


#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <stdexcept>

namespace sensor_rig::rig {
namespace {

std::string tc_binary() {
  const char* tc = std::getenv("RIG_TC");
  return tc != nullptr && *tc != '\0' ? tc : "tc";
}

// Runs `tc ARGS`; its exit status and what it said.
std::pair<int, std::string> tc(const std::string& args) {
  const std::string cmd = tc_binary() + " " + args + " 2>&1";
  std::string out;
  FILE* f = ::popen(cmd.c_str(), "r");
  if (f == nullptr) return {-1, "cannot run " + tc_binary()};
  char buf[512];
  while (std::fgets(buf, sizeof buf, f) != nullptr) out += buf;
  const int st = ::pclose(f);
  while (!out.empty() && (out.back() == '\n' || out.back() == ' ')) out.pop_back();
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, out};
}

constexpr const char* kRoot = "dev lo root handle 1:";
// Every priority to band 2 (class 1:2): only the filters send traffic to the netem band (1:3).
constexpr const char* kPrio = "qdisc add dev lo root handle 1: prio bands 3 priomap 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1 1";

std::string number(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3f", v);
  return b;
}

// Makes the shaping; on failure removes what was made and returns tc's answer.
std::string shape(double ms, double jitter_ms, const std::vector<int>& ports) {
  std::vector<std::string> steps{kPrio, "qdisc add dev lo parent 1:3 handle 30: netem delay " + number(ms) + "ms" +
                                            (jitter_ms > 0 ? " " + number(jitter_ms) + "ms" : std::string{})};
  for (const int p : ports)
    steps.push_back("filter add dev lo parent 1: protocol ip prio 1 u32 match ip protocol 17 0xff match ip dport " +
                    std::to_string(p) + " 0xffff flowid 1:3");
  for (const auto& s : steps) {
    const auto [rc, said] = tc(s);
    if (rc != 0) {
      if (s != kPrio) tc(std::string("qdisc del ") + kRoot);
      return "tc " + s + ": " + (said.empty() ? "exit " + std::to_string(rc) : said);
    }
  }
  return {};
}

}  // namespace

std::string LoopbackDelay::unavailable() {
  static std::once_flag once;
  static std::string why;
  std::call_once(once, [] {
    const auto [rc, shown] = tc("qdisc show dev lo");
    if (rc != 0) {
      why = tc_binary() + " qdisc show dev lo: " + (shown.empty() ? "exit " + std::to_string(rc) : shown);
      return;
    }
    if (shown.find("qdisc noqueue 0: root") == std::string::npos && shown.find("qdisc pfifo_fast 0: root") == std::string::npos &&
        !shown.empty()) {
      why = "lo has a root qdisc of its own (" + shown.substr(0, shown.find('\n')) + "): not replaced";
      return;
    }
    why = shape(0, 0, {});
    if (why.empty()) tc(std::string("qdisc del ") + kRoot);
  });
  return why;
}

LoopbackDelay::LoopbackDelay(double ms, double jitter_ms, const std::vector<int>& udp_ports)
    : hold_ms_(ms + jitter_ms), record_("net-delay", "lo\n") {
  if (const std::string why = shape(ms, jitter_ms, udp_ports); !why.empty()) {
    record_.remove();
    throw std::runtime_error(why);
  }
}

LoopbackDelay::~LoopbackDelay() {
  // The filters first: new packets pass at once; those netem holds leave at their time. Deleting the
  // qdisc at once would drop them (a loss the mocks' truth knows nothing of).
  tc("filter del dev lo parent 1: prio 1");
  ::usleep(static_cast<useconds_t>((hold_ms_ + 20.0) * 1000.0));
  tc(std::string("qdisc del ") + kRoot);
  record_.remove();
}

std::vector<std::string> LoopbackDelay::sweep() {
  std::vector<std::string> undone;
  for (const auto& o : HostChangeRecord::orphans("net-delay")) {
    const auto [rc, said] = tc(std::string("qdisc del ") + kRoot);
    undone.push_back(rc == 0 ? "removed the netem delay on lo: a campaign (pid " + std::to_string(o.pid) +
                                   ") ended without removing it"
                             : "a campaign (pid " + std::to_string(o.pid) + ") left a netem delay record; tc qdisc del: " + said);
    HostChangeRecord::remove_orphan(o);
  }
  return undone;
}

}  // namespace sensor_rig::rig
