#include <charconv>
#include <cstdlib>
#include <map>
#include <optional>
#include <mutex>

#include "replay_transport.hpp"
#include "seqpacket_transport.hpp"
#include "socketcan_transport.hpp"

namespace sensor_rig::dbw::can {
namespace {

std::mutex& kinds_mu() {
  static std::mutex mu;
  return mu;
}
std::map<std::string, FrameLogOpener>& log_kinds() {
  static std::map<std::string, FrameLogOpener> kinds;
  return kinds;
}

struct Replay {
  std::string path;
  double rate = 1.0;
  std::optional<Nanos> delay_ns;
};

// FILE[@RATE[,DELAY_S]]: after the last '@' the speed factor (0 = as fast as possible; 1 without)
// and, after a comma, the seconds before the first frame.
Replay parse_replay(std::string_view spec, const std::string& arg) {
  Replay r;
  r.path = arg;
  const auto at = arg.rfind('@');
  if (at == std::string::npos) return r;
  r.path = arg.substr(0, at);
  const std::string tail = arg.substr(at + 1);
  const auto comma = tail.find(',');
  const auto number = [&](const std::string& text, const char* what) {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || *end != '\0' || !(v >= 0.0) || v > 1e6)
      throw TransportError("transport '" + std::string(spec) + "': bad " + what + " '" + text + "'");
    return v;
  };
  r.rate = number(tail.substr(0, comma), "rate");
  if (comma != std::string::npos)
    r.delay_ns = static_cast<Nanos>(number(tail.substr(comma + 1), "delay") * 1e9);
  return r;
}

}  // namespace

void register_frame_log_kind(const std::string& kind, FrameLogOpener open) {
  std::lock_guard lock(kinds_mu());
  log_kinds()[kind] = open;
}

std::unique_ptr<Transport> open_transport(std::string_view spec) {
  const auto colon = spec.find(':');
  if (colon == std::string_view::npos) {
    throw TransportError("transport '" + std::string(spec) +
                         "': expected socketcan:IFACE, unix:PATH, unix-listen:PATH, fd:N or candump:FILE[@RATE]");
  }
  const std::string kind(spec.substr(0, colon));
  const std::string arg(spec.substr(colon + 1));
  if (arg.empty()) throw TransportError("transport '" + std::string(spec) + "': missing argument after ':'");
  if (kind == "socketcan") return std::make_unique<SocketCanTransport>(arg);
  if (kind == "unix") return SeqpacketTransport::connect(arg);
  if (kind == "unix-listen") return std::make_unique<BusListener>(arg);
  if (kind == "fd" || kind == "socketpair") {
    int fd = -1;
    const auto r = std::from_chars(arg.data(), arg.data() + arg.size(), fd);
    if (r.ec != std::errc{} || r.ptr != arg.data() + arg.size() || fd < 0) {
      throw TransportError("transport '" + std::string(spec) + "': not a descriptor number");
    }
    return std::make_unique<SeqpacketTransport>(UniqueFd(fd), kind + ":" + arg);
  }
  if (kind == "candump") {
    const Replay r = parse_replay(spec, arg);
    return std::make_unique<ReplayTransport>(std::make_unique<CandumpFrameLog>(r.path), "candump:" + r.path, r.rate,
                                             r.delay_ns.value_or(0));
  }
  FrameLogOpener open = nullptr;
  {
    std::lock_guard lock(kinds_mu());
    if (const auto it = log_kinds().find(kind); it != log_kinds().end()) open = it->second;
  }
  if (open != nullptr) {
    const Replay r = parse_replay(spec, arg);
    std::unique_ptr<FrameLog> log;
    try {
      log = open(r.path);
    } catch (const TransportError&) {
      throw;
    } catch (const std::exception& e) {
      throw TransportError(kind + ":" + r.path + ": " + e.what());
    }
    const Nanos delay = r.delay_ns.value_or(log->default_delay_ns());
    return std::make_unique<ReplayTransport>(std::move(log), kind + ":" + r.path, r.rate, delay);
  }
  throw TransportError("unknown transport kind '" + kind + "' in '" + std::string(spec) + "'");
}

}  // namespace sensor_rig::dbw::can
