#pragma once
// Network namespaces joined by veth pairs (MTU 1500, no routing), made for one test and always
// removed: the ring source's two-namespace link and the car's three computers of the several-hosts
// end-to-end tests. A test killed before its destructor ran (ctest's timeout) leaves its
// namespaces: the next NetworkNamespaces removes those of processes that no longer run. Names are
// unique per process and instance. Needs CAP_SYS_ADMIN and `ip`; `error()` says why when
// something could not be set up (the test skips with it).
#include <dirent.h>
#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <exception>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace sensor_rig::test {

class NetworkNamespaces {
 public:
  struct End {
    std::string ns, interface, address;  // address without prefix length: /24 is added
  };

  NetworkNamespaces() {
    static std::atomic<int> counter{0};
    tag_ = std::to_string(::getpid()) + "_" + std::to_string(counter++);
    remove_orphans();
  }
  ~NetworkNamespaces() {  // deleting a namespace deletes its ends of the veth pairs (and its vcans)
    for (const auto& ns : created_) run("ip netns del " + ns);
  }
  NetworkNamespaces(const NetworkNamespaces&) = delete;
  NetworkNamespaces& operator=(const NetworkNamespaces&) = delete;

  // A new namespace "rig<letter>_<tag>" with lo up; "" (and error()) when it cannot be made.
  std::string add(const std::string& letter) {
    const std::string ns = "rig" + letter + "_" + tag_;
    if (!run("ip netns add " + ns)) {
      fail("cannot create network namespaces (needs CAP_SYS_ADMIN and iproute2): ip netns add " + ns + " failed");
      return "";
    }
    created_.push_back(ns);
    if (!run(in(ns) + "ip link set lo up")) fail("cannot set lo up in " + ns);
    return ns;
  }
  // An interface name unique to this instance: `prefix` (two letters) + tag, <= 15 chars (IFNAMSIZ).
  [[nodiscard]] std::string interface_name(const std::string& prefix) const { return (prefix + tag_).substr(0, 15); }

  // A veth pair between a.ns and b.ns, each end addressed /24 and up.
  bool link(const End& a, const End& b) {
    const bool ok = run("ip link add " + a.interface + " netns " + a.ns + " type veth peer name " + b.interface +
                        " netns " + b.ns) &&
                    up(a) && up(b);
    if (!ok) fail("cannot set up the veth pair between " + a.ns + " and " + b.ns);
    return ok;
  }
  // A virtual CAN interface in `ns`, up; false (error() unchanged) where the kernel has no vcan.
  static bool add_vcan(const std::string& ns, const std::string& interface) {
    return run(in(ns) + "ip link add " + interface + " type vcan") && run(in(ns) + "ip link set " + interface + " up");
  }

  [[nodiscard]] const std::string& error() const { return error_; }

  // argv run inside namespace `ns`, for ChildProcess (execve: env finds `ip` on PATH; env and
  // ip netns exec both exec, so the pid is the program's own).
  static std::vector<std::string> command_in(const std::string& ns, std::vector<std::string> argv) {
    argv.insert(argv.begin(), {"/usr/bin/env", "ip", "netns", "exec", ns});
    return argv;
  }
  // Runs f() on a thread moved into namespace `ns` (setns): sockets it creates stay in that
  // namespace when used from any thread afterwards. Rethrows what f throws.
  template <class F>
  static void run_in(const std::string& ns, F&& f) {
    std::exception_ptr error;
    std::thread t([&] {
      try {
        const int fd = ::open(("/run/netns/" + ns).c_str(), O_RDONLY | O_CLOEXEC);
        const bool entered = fd >= 0 && ::setns(fd, CLONE_NEWNET) == 0;
        if (fd >= 0) ::close(fd);
        if (!entered) throw std::runtime_error("setns into " + ns + " failed");
        f();
      } catch (...) {
        error = std::current_exception();
      }
    });
    t.join();
    if (error) std::rethrow_exception(error);
  }

  // Namespaces of test processes that ended without their destructor (killed at a timeout):
  // "rig<letter>_<pid>_<n>" whose pid no longer runs. Deleting one deletes its veth ends too.
  static void remove_orphans() {
    DIR* dir = ::opendir("/run/netns");
    if (dir == nullptr) return;
    std::vector<std::string> orphans;
    while (const dirent* e = ::readdir(dir)) {
      const std::string name = e->d_name;
      if (name.size() < 6 || name.rfind("rig", 0) != 0 || name[4] != '_') continue;
      const long pid = std::strtol(name.c_str() + 5, nullptr, 10);
      if (pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) orphans.push_back(name);
    }
    ::closedir(dir);
    for (const auto& ns : orphans) run("ip netns del " + ns);
  }

 private:
  static std::string in(const std::string& ns) { return "ip netns exec " + ns + " "; }
  static bool run(const std::string& cmd) { return std::system((cmd + " >/dev/null 2>&1").c_str()) == 0; }
  static bool up(const End& e) {
    return run(in(e.ns) + "ip addr add " + e.address + "/24 dev " + e.interface) &&
           run(in(e.ns) + "ip link set " + e.interface + " mtu 1500 up");
  }
  void fail(const std::string& why) {
    if (error_.empty()) error_ = why;
  }

  std::string tag_, error_;
  std::vector<std::string> created_;
};

// Two namespaces joined by one veth pair: <a> 10.213.0.1/24, <b> 10.213.0.2/24.
class VethPair {
 public:
  static constexpr const char* kAddrA = "10.213.0.1";
  static constexpr const char* kAddrB = "10.213.0.2";

  VethPair()
      : ns_a_(net_.add("A")),
        ns_b_(net_.error().empty() ? net_.add("B") : ""),
        if_a_(net_.interface_name("va")),
        if_b_(net_.interface_name("vb")) {
    if (net_.error().empty()) net_.link({ns_a_, if_a_, kAddrA}, {ns_b_, if_b_, kAddrB});
  }

  [[nodiscard]] const std::string& error() const { return net_.error(); }
  [[nodiscard]] const std::string& ns_a() const { return ns_a_; }
  [[nodiscard]] const std::string& ns_b() const { return ns_b_; }
  [[nodiscard]] const std::string& if_a() const { return if_a_; }
  [[nodiscard]] const std::string& if_b() const { return if_b_; }

 private:
  NetworkNamespaces net_;
  std::string ns_a_, ns_b_, if_a_, if_b_;
};

// The car's three computers:
//   sensors (mock LIDARs, GigE cameras) 10.214.1.1 <-veth-> 10.214.1.2 PU 10.214.2.1 <-veth-> 10.214.2.2 planning
// The PU has two NICs, as on the car: one on the sensor network, one on the vehicle network.
class VehicleNetwork {
 public:
  static constexpr const char* kSensorAddr = "10.214.1.1";
  static constexpr const char* kPuSensorAddr = "10.214.1.2";
  static constexpr const char* kPuVehicleAddr = "10.214.2.1";
  static constexpr const char* kPlanningAddr = "10.214.2.2";

  VehicleNetwork()
      : sensors_(net_.add("S")),
        pu_(net_.error().empty() ? net_.add("P") : ""),
        planning_(net_.error().empty() ? net_.add("C") : ""),
        sensors_if_(net_.interface_name("ss")),
        pu_sensor_if_(net_.interface_name("ps")),
        pu_vehicle_if_(net_.interface_name("pv")),
        planning_if_(net_.interface_name("cv")) {
    if (net_.error().empty()) net_.link({sensors_, sensors_if_, kSensorAddr}, {pu_, pu_sensor_if_, kPuSensorAddr});
    if (net_.error().empty()) net_.link({pu_, pu_vehicle_if_, kPuVehicleAddr}, {planning_, planning_if_, kPlanningAddr});
  }

  [[nodiscard]] const std::string& error() const { return net_.error(); }
  [[nodiscard]] const std::string& sensors() const { return sensors_; }
  [[nodiscard]] const std::string& pu() const { return pu_; }
  [[nodiscard]] const std::string& planning() const { return planning_; }
  [[nodiscard]] const std::string& sensors_if() const { return sensors_if_; }
  [[nodiscard]] const std::string& pu_sensor_if() const { return pu_sensor_if_; }
  [[nodiscard]] const std::string& pu_vehicle_if() const { return pu_vehicle_if_; }
  [[nodiscard]] const std::string& planning_if() const { return planning_if_; }
  [[nodiscard]] std::string interface_name(const std::string& prefix) const { return net_.interface_name(prefix); }

 private:
  NetworkNamespaces net_;
  std::string sensors_, pu_, planning_, sensors_if_, pu_sensor_if_, pu_vehicle_if_, planning_if_;
};

}  // namespace sensor_rig::test
