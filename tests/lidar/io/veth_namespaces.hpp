#pragma once
// Two network namespaces joined by a veth pair (MTU 1500), made for one test and always removed:
// <a> has 10.213.0.1/24 on its end, <b> 10.213.0.2/24. Names are unique per process and instance.
// in_namespace() runs a function on a thread moved into a namespace (setns): sockets it creates
// stay in that namespace when used from any thread afterwards. Needs CAP_SYS_ADMIN and `ip`;
// `error()` says why when it could not be set up (the test skips with it).
#include <fcntl.h>
#include <sched.h>
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <exception>
#include <string>
#include <thread>

namespace sensor_rig::lidar::test {

class VethNamespaces {
 public:
  static constexpr const char* kAddrA = "10.213.0.1";
  static constexpr const char* kAddrB = "10.213.0.2";

  VethNamespaces() {
    static std::atomic<int> counter{0};
    const std::string tag = std::to_string(::getpid()) + "_" + std::to_string(counter++);
    ns_a_ = "rigA_" + tag;
    ns_b_ = "rigB_" + tag;
    if_a_ = "vra" + tag;  // <= 15 characters (IFNAMSIZ)
    if_b_ = "vrb" + tag;
    if (if_a_.size() > 15) if_a_ = if_a_.substr(0, 15), if_b_ = if_b_.substr(0, 15);
    if (!run("ip netns add " + ns_a_)) {
      error_ = "cannot create network namespaces (needs CAP_SYS_ADMIN and iproute2): ip netns add failed";
      return;
    }
    created_a_ = true;
    created_b_ = run("ip netns add " + ns_b_);
    const bool ok = created_b_ && run("ip link add " + if_a_ + " netns " + ns_a_ + " type veth peer name " + if_b_ +
                                      " netns " + ns_b_) &&
                    run(in(ns_a_) + "ip addr add " + kAddrA + "/24 dev " + if_a_) &&
                    run(in(ns_b_) + "ip addr add " + kAddrB + "/24 dev " + if_b_) &&
                    run(in(ns_a_) + "ip link set " + if_a_ + " mtu 1500 up") &&
                    run(in(ns_b_) + "ip link set " + if_b_ + " mtu 1500 up") && run(in(ns_a_) + "ip link set lo up") &&
                    run(in(ns_b_) + "ip link set lo up");
    if (!ok) error_ = "cannot set up the veth pair between " + ns_a_ + " and " + ns_b_;
  }
  ~VethNamespaces() {  // deleting a namespace deletes its end of the veth pair, and so the pair
    if (created_a_) run("ip netns del " + ns_a_);
    if (created_b_) run("ip netns del " + ns_b_);
  }
  VethNamespaces(const VethNamespaces&) = delete;
  VethNamespaces& operator=(const VethNamespaces&) = delete;

  [[nodiscard]] const std::string& error() const { return error_; }
  [[nodiscard]] const std::string& ns_a() const { return ns_a_; }
  [[nodiscard]] const std::string& ns_b() const { return ns_b_; }
  [[nodiscard]] const std::string& if_a() const { return if_a_; }
  [[nodiscard]] const std::string& if_b() const { return if_b_; }

  // Runs f() on a thread inside namespace `ns`; rethrows what f throws.
  template <class F>
  static void in_namespace(const std::string& ns, F&& f) {
    std::exception_ptr error;
    std::thread t([&] {
      try {
        const int fd = ::open(("/run/netns/" + ns).c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0 || ::setns(fd, CLONE_NEWNET) != 0) throw std::runtime_error("setns into " + ns + " failed");
        ::close(fd);
        f();
      } catch (...) {
        error = std::current_exception();
      }
    });
    t.join();
    if (error) std::rethrow_exception(error);
  }

 private:
  static std::string in(const std::string& ns) { return "ip netns exec " + ns + " "; }
  static bool run(const std::string& cmd) { return std::system((cmd + " >/dev/null 2>&1").c_str()) == 0; }

  std::string ns_a_, ns_b_, if_a_, if_b_, error_;
  bool created_a_ = false;
  bool created_b_ = false;
};

}  // namespace sensor_rig::lidar::test
