#include "sensor_rig/common/loopback_address.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <ifaddrs.h>
#include <linux/netlink.h>
#include <linux/rtnetlink.h>
#include <net/if.h>
#include <netinet/in.h>
#include <sys/file.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <utility>

#include "sensor_rig/common/unique_fd.hpp"

namespace sensor_rig {
namespace {

std::string state_dir() {
  const char* dir = std::getenv("RIG_STATE_DIR");
  return dir != nullptr && *dir != '\0' ? dir : "/run/sensor-rig";
}

// A process is identified by its pid and its start time (clock ticks since boot): a pid reused by
// another process after the holder died is not the holder.
std::string start_time_of(long pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return "";
  const auto paren = line.rfind(')');  // the command name may hold spaces and parentheses
  if (paren == std::string::npos) return "";
  std::istringstream fields(line.substr(paren + 2));
  std::string field;
  for (int i = 3; i <= 22 && fields >> field; ++i)  // field 22: starttime
    if (i == 22) return field;
  return "";
}

struct Holder {
  std::string address;
  long pid = 0;
  std::string start_time;
  [[nodiscard]] bool alive() const { return start_time_of(pid) == start_time; }
};

std::optional<in_addr> parse_ipv4(const std::string& address) {
  in_addr a{};
  if (::inet_pton(AF_INET, address.c_str(), &a) != 1) return std::nullopt;
  return a;
}

// RTM_NEWADDR / RTM_DELADDR of address/8 on lo; 0 or the errno the kernel answered.
int change_lo_address(int type, in_addr address) {
  UniqueFd fd(::socket(AF_NETLINK, SOCK_RAW | SOCK_CLOEXEC, NETLINK_ROUTE));
  if (!fd) return errno;
  struct {
    nlmsghdr header;
    ifaddrmsg ifa;
    char attributes[64];
  } request{};
  request.header.nlmsg_len = NLMSG_LENGTH(sizeof(ifaddrmsg));
  request.header.nlmsg_type = static_cast<std::uint16_t>(type);
  request.header.nlmsg_flags = NLM_F_REQUEST | NLM_F_ACK | (type == RTM_NEWADDR ? NLM_F_CREATE | NLM_F_EXCL : 0);
  request.header.nlmsg_seq = 1;
  request.ifa.ifa_family = AF_INET;
  request.ifa.ifa_prefixlen = 8;
  request.ifa.ifa_scope = RT_SCOPE_HOST;
  request.ifa.ifa_index = ::if_nametoindex("lo");
  if (request.ifa.ifa_index == 0) return ENODEV;
  for (const auto kind : {IFA_LOCAL, IFA_ADDRESS}) {
    auto* attribute = reinterpret_cast<rtattr*>(reinterpret_cast<char*>(&request) + NLMSG_ALIGN(request.header.nlmsg_len));
    attribute->rta_type = kind;
    attribute->rta_len = RTA_LENGTH(sizeof address);
    std::memcpy(reinterpret_cast<char*>(attribute) + RTA_LENGTH(0), &address, sizeof address);  // RTA_DATA
    request.header.nlmsg_len = NLMSG_ALIGN(request.header.nlmsg_len) + RTA_ALIGN(attribute->rta_len);
  }
  sockaddr_nl kernel{};
  kernel.nl_family = AF_NETLINK;
  if (::sendto(fd.get(), &request, request.header.nlmsg_len, 0, reinterpret_cast<sockaddr*>(&kernel), sizeof kernel) < 0)
    return errno;
  // The acknowledgement: an NLMSG_ERROR whose error is 0, or minus the errno. Bounded: the kernel
  // answers at once, a second is generous.
  timeval timeout{1, 0};
  ::setsockopt(fd.get(), SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  alignas(nlmsghdr) char answer[1024];
  const ssize_t n = ::recv(fd.get(), answer, sizeof answer, 0);
  if (n < 0) return errno;
  const auto* header = reinterpret_cast<const nlmsghdr*>(answer);
  if (!NLMSG_OK(header, static_cast<unsigned>(n)) || header->nlmsg_type != NLMSG_ERROR) return EPROTO;
  nlmsgerr error{};  // NLMSG_DATA, without its C cast
  if (static_cast<std::size_t>(n) < NLMSG_HDRLEN + sizeof error) return EPROTO;
  std::memcpy(&error, answer + NLMSG_HDRLEN, sizeof error);
  return -error.error;
}

// The registry, locked for as long as this lives. The file is removed (with its folder) when the
// last address leaves it; a process that opened it just before waits for the lock, finds the name
// now leads elsewhere (or nowhere) and opens it again.
class Registry {
 public:
  Registry() {
    const std::string dir = state_dir();
    path_ = dir + "/loopback-addresses";
    for (int attempt = 0; attempt < 100; ++attempt) {
      ::mkdir(dir.c_str(), 0755);
      UniqueFd fd(::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644));
      if (!fd) {
        if (errno == ENOENT) continue;  // the folder went away between mkdir and open
        error_ = path_ + ": " + std::strerror(errno);
        return;
      }
      if (::flock(fd.get(), LOCK_EX) != 0) {
        error_ = path_ + ": flock: " + std::strerror(errno);
        return;
      }
      struct stat held{}, named{};
      if (::fstat(fd.get(), &held) == 0 && ::stat(path_.c_str(), &named) == 0 && held.st_ino == named.st_ino &&
          held.st_dev == named.st_dev) {
        fd_ = std::move(fd);
        read();
        return;
      }
    }
    error_ = path_ + ": could not be locked";
  }
  Registry(const Registry&) = delete;
  Registry& operator=(const Registry&) = delete;
  ~Registry() { save(); }

  // Writes the holders (or removes the empty registry). Called before an address is added, so
  // that a holder killed right after the kernel added it has it recorded.
  void save() {
    if (!fd_) return;
    if (holders_.empty()) {
      ::unlink(path_.c_str());
      ::rmdir(state_dir().c_str());  // fails, harmlessly, while it holds anything else
      fd_.reset();  // the name is gone: nothing more to write through this file
    } else {
      write();
    }
  }

  [[nodiscard]] bool ok() const { return static_cast<bool>(fd_); }
  [[nodiscard]] const std::string& error() const { return error_; }
  std::vector<Holder>& holders() { return holders_; }
  [[nodiscard]] bool recorded(const std::string& address) const {
    return std::any_of(holders_.begin(), holders_.end(), [&](const Holder& h) { return h.address == address; });
  }

  // Removes the addresses none of whose holders lives; returns them.
  std::vector<std::string> sweep() {
    std::vector<std::string> live, dead;
    for (const auto& h : holders_) (h.alive() ? live : dead).push_back(h.address);
    std::vector<std::string> removed;
    for (const auto& address : dead) {
      if (std::find(live.begin(), live.end(), address) != live.end()) continue;
      if (std::find(removed.begin(), removed.end(), address) != removed.end()) continue;
      const auto a = parse_ipv4(address);
      if (a && host_has_address(address)) change_lo_address(RTM_DELADDR, *a);
      removed.push_back(address);
    }
    std::erase_if(holders_, [](const Holder& h) { return !h.alive(); });
    return removed;
  }

 private:
  void read() {
    std::string text(4096, '\0');
    std::string all;
    ssize_t n = 0;
    ::lseek(fd_.get(), 0, SEEK_SET);
    while ((n = ::read(fd_.get(), text.data(), text.size())) > 0) all.append(text.data(), static_cast<std::size_t>(n));
    std::istringstream lines(all);
    Holder h;
    while (lines >> h.address >> h.pid >> h.start_time) holders_.push_back(h);
  }
  void write() {
    std::ostringstream o;
    for (const auto& h : holders_) o << h.address << ' ' << h.pid << ' ' << h.start_time << '\n';
    const std::string text = o.str();
    if (::ftruncate(fd_.get(), 0) != 0 || ::pwrite(fd_.get(), text.data(), text.size(), 0) < 0) {
      // The lock stays ours until close: nothing to undo, the next holder reads what is there.
    }
  }

  std::string path_;
  std::string error_;
  UniqueFd fd_;
  std::vector<Holder> holders_;
};

Holder self(const std::string& address) {
  const long pid = ::getpid();
  return Holder{address, pid, start_time_of(pid)};
}

}  // namespace

bool host_has_address(const std::string& address) {
  const auto want = parse_ipv4(address);
  if (!want) return false;
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return false;
  bool found = false;
  for (ifaddrs* i = list; i != nullptr && !found; i = i->ifa_next) {
    if (i->ifa_addr == nullptr || i->ifa_addr->sa_family != AF_INET) continue;
    sockaddr_in sin{};
    std::memcpy(&sin, i->ifa_addr, sizeof sin);
    found = sin.sin_addr.s_addr == want->s_addr;
  }
  ::freeifaddrs(list);
  return found;
}

std::string LoopbackAddress::registry_path() { return state_dir() + "/loopback-addresses"; }

std::vector<std::string> LoopbackAddress::sweep() {
  Registry registry;
  return registry.ok() ? registry.sweep() : std::vector<std::string>{};
}

std::optional<LoopbackAddress> LoopbackAddress::take(const std::string& address, std::string& why) {
  const auto a = parse_ipv4(address);
  if (!a) {
    why = "'" + address + "' is not an IPv4 address";
    return std::nullopt;
  }
  const bool loopback = (ntohl(a->s_addr) >> 24) == 127;
  if (!loopback) {
    if (host_has_address(address)) return LoopbackAddress(address, false);
    why = address + " is on no interface (only 127.0.0.0/8 addresses are added to lo)";
    return std::nullopt;
  }
  Registry registry;
  if (!registry.ok()) {
    // No registry (a user without write access to it): an address already there is used as it
    // is; none is added, as it could not be recorded for removal.
    if (host_has_address(address)) return LoopbackAddress(address, false);
    why = "cannot add " + address + " to lo: " + registry.error();
    return std::nullopt;
  }
  registry.sweep();
  const bool present = host_has_address(address);
  if (present && !registry.recorded(address)) return LoopbackAddress(address, false);  // the host's own
  // Recorded first, added then: killed in between, the next sweep finds a record and no address.
  registry.holders().push_back(self(address));
  registry.save();
  if (!present) {
    const int error = change_lo_address(RTM_NEWADDR, *a);
    if (error != 0 && error != EEXIST) {
      registry.holders().pop_back();
      why = "cannot add " + address + " to lo: " + std::strerror(error) +
            (error == EPERM ? " (needs root or CAP_NET_ADMIN)" : "");
      return std::nullopt;
    }
  }
  return LoopbackAddress(address, true);
}

LoopbackAddress::LoopbackAddress(LoopbackAddress&& other) noexcept
    : address_(std::move(other.address_)), recorded_(std::exchange(other.recorded_, false)) {}

LoopbackAddress& LoopbackAddress::operator=(LoopbackAddress&& other) noexcept {
  if (this != &other) {
    release();
    address_ = std::move(other.address_);
    recorded_ = std::exchange(other.recorded_, false);
  }
  return *this;
}

LoopbackAddress::~LoopbackAddress() { release(); }

void LoopbackAddress::release() noexcept {
  if (!std::exchange(recorded_, false)) return;
  try {
    Registry registry;
    if (!registry.ok()) return;
    auto& holders = registry.holders();
    const Holder me = self(address_);
    // One line per lease: a process holding the address twice keeps it until its second lease ends.
    const auto mine = std::find_if(holders.begin(), holders.end(), [&](const Holder& h) {
      return h.address == me.address && h.pid == me.pid && h.start_time == me.start_time;
    });
    if (mine != holders.end()) holders.erase(mine);
    registry.sweep();
    if (!registry.recorded(address_))
      if (const auto a = parse_ipv4(address_)) change_lo_address(RTM_DELADDR, *a);
  } catch (...) {
    // A destructor: the next take or sweep removes what this could not.
  }
}

}  // namespace sensor_rig
