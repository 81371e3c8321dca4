#pragma once
// Runs tests/js/view_client.mjs (the Foxglove client written by others, @foxglove/ws-protocol, on
// Node.js) as a separate process and collects its JSON lines: how the tests look at `rig view` and
// the view server from outside. Needs node and tests/js/node_modules (scripts/setup.sh installs
// them with `npm ci`); a test says which is missing instead of running without them.
#include <poll.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "sensor_rig/common/child_process.hpp"
#include "sensor_rig/common/clock.hpp"
#include "test_data.hpp"

namespace sensor_rig::test {

// Empty when the client can run, else what is missing.
inline std::string view_client_missing() {
  const auto js = source_dir() / "tests/js";
  if (::access("/usr/bin/node", X_OK) != 0) return "no /usr/bin/node (install nodejs: scripts/setup.sh)";
  if (!std::filesystem::exists(js / "node_modules/@foxglove/ws-protocol"))
    return "no " + (js / "node_modules/@foxglove/ws-protocol").string() + " (run scripts/setup.sh: npm ci in tests/js)";
  return "";
}

// 32-bit FNV-1a, as view_client.mjs summarises byte arrays.
inline std::uint32_t fnv1a(const std::uint8_t* p, std::size_t n) {
  std::uint32_t h = 0x811c9dc5u;
  for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 0x01000193u;
  return h;
}

class ViewClient {
 public:
  explicit ViewClient(const std::vector<std::string>& args) {
    std::vector<std::string> argv = {"/usr/bin/node", (source_dir() / "tests/js/view_client.mjs").string()};
    argv.insert(argv.end(), args.begin(), args.end());
    ChildOptions o;
    o.pipe_stdio = true;
    proc_ = ChildProcess(argv, o);
  }

  // Reads lines until the process exits or `ms` pass; returns whether it exited.
  bool wait_exit(int ms) {
    const Nanos deadline = monotonic_now_ns() + Nanos{ms} * 1'000'000;
    while (monotonic_now_ns() < deadline) {
      collect(50);
      if (proc_.stdout_eof() && !proc_.running()) return true;
    }
    collect(0);
    return !proc_.running();
  }
  // Reads what is available for up to `ms`.
  void collect(int ms) {
    pollfd p{proc_.stdout_fd(), POLLIN, 0};
    if (p.fd >= 0 && !proc_.stdout_eof()) ::poll(&p, 1, ms);
    for (auto& l : proc_.read_lines()) {
      auto j = nlohmann::json::parse(l, nullptr, false);
      if (j.is_discarded()) j = nlohmann::json{{"event", "unparsed"}, {"line", l}};
      lines_.push_back(std::move(j));
    }
  }
  // The lines of one event kind so far.
  [[nodiscard]] std::vector<nlohmann::json> events(const std::string& kind) const {
    std::vector<nlohmann::json> r;
    for (const auto& l : lines_)
      if (l.value("event", "") == kind) r.push_back(l);
    return r;
  }
  [[nodiscard]] const std::vector<nlohmann::json>& lines() const { return lines_; }
  [[nodiscard]] nlohmann::json summary() const {
    const auto s = events("summary");
    return s.empty() ? nlohmann::json() : s.back();
  }
  [[nodiscard]] int exit_status() const { return proc_.exit_status(); }
  void stop() { proc_.stop(1000); }
  // Everything it printed, for failure messages.
  [[nodiscard]] std::string transcript(std::size_t max_chars = 4000) const {
    std::string s;
    for (const auto& l : lines_) {
      auto copy = l;
      if (copy.contains("summary") && copy.value("event", "") == "message") copy.erase("summary");
      s += copy.dump() + "\n";
      if (s.size() > max_chars) return s.substr(0, max_chars) + "...";
    }
    return s;
  }

 private:
  ChildProcess proc_;
  std::vector<nlohmann::json> lines_;
};

}  // namespace sensor_rig::test
