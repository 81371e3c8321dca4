#include <charconv>
#include <cstdlib>

#include "replay_transport.hpp"
#include "seqpacket_transport.hpp"
#include "socketcan_transport.hpp"

namespace sensor_rig::dbw::can {

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
    double rate = 1.0;
    std::string path = arg;
    if (const auto at = arg.rfind('@'); at != std::string::npos) {
      char* end = nullptr;
      rate = std::strtod(arg.c_str() + at + 1, &end);
      if (end == arg.c_str() + at + 1 || *end != '\0') throw TransportError("transport '" + std::string(spec) + "': bad rate");
      path = arg.substr(0, at);
    }
    return std::make_unique<ReplayTransport>(path, rate);
  }
  throw TransportError("unknown transport kind '" + kind + "' in '" + std::string(spec) + "'");
}

}  // namespace sensor_rig::dbw::can
