#pragma once
// The car's three computers as network namespaces, made for one test and always removed:
//   sensors (mock LIDARs) 10.214.1.1 <-veth-> 10.214.1.2 PU 10.214.2.1 <-veth-> 10.214.2.2 planning
// The PU has two NICs, as on the car: one on the sensor network, one on the vehicle network. No
// routing between them. Names are unique per process and instance; needs CAP_SYS_ADMIN and `ip`;
// `error()` says why when it could not be set up (the test skips with it).
#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <string>
#include <vector>

namespace sensor_rig::test {

class VehicleNetwork {
 public:
  static constexpr const char* kSensorAddr = "10.214.1.1";
  static constexpr const char* kPuSensorAddr = "10.214.1.2";
  static constexpr const char* kPuVehicleAddr = "10.214.2.1";
  static constexpr const char* kPlanningAddr = "10.214.2.2";

  VehicleNetwork() {
    static std::atomic<int> counter{0};
    const std::string tag = std::to_string(::getpid()) + "_" + std::to_string(counter++);
    sensors_ = "rigS_" + tag, pu_ = "rigP_" + tag, planning_ = "rigC_" + tag;
    // <= 15 characters (IFNAMSIZ): two letters + pid + counter
    auto ifname = [&](const char* p) { return (std::string(p) + tag).substr(0, 15); };
    sensors_if_ = ifname("ss"), pu_sensor_if_ = ifname("ps"), pu_vehicle_if_ = ifname("pv"),
    planning_if_ = ifname("cv");
    for (const auto* ns : {&sensors_, &pu_, &planning_}) {
      if (!run("ip netns add " + *ns)) {
        error_ = "cannot create network namespaces (needs CAP_SYS_ADMIN and iproute2): ip netns add " + *ns + " failed";
        return;
      }
      created_.push_back(*ns);
    }
    const bool ok = link(sensors_, sensors_if_, kSensorAddr, pu_, pu_sensor_if_, kPuSensorAddr) &&
                    link(pu_, pu_vehicle_if_, kPuVehicleAddr, planning_, planning_if_, kPlanningAddr) &&
                    run(in(sensors_) + "ip link set lo up") && run(in(pu_) + "ip link set lo up") &&
                    run(in(planning_) + "ip link set lo up");
    if (!ok) error_ = "cannot set up the veth pairs between " + sensors_ + ", " + pu_ + " and " + planning_;
  }
  ~VehicleNetwork() {  // deleting a namespace deletes its ends of the veth pairs
    for (const auto& ns : created_) run("ip netns del " + ns);
  }
  VehicleNetwork(const VehicleNetwork&) = delete;
  VehicleNetwork& operator=(const VehicleNetwork&) = delete;

  [[nodiscard]] const std::string& error() const { return error_; }
  [[nodiscard]] const std::string& sensors() const { return sensors_; }
  [[nodiscard]] const std::string& pu() const { return pu_; }
  [[nodiscard]] const std::string& planning() const { return planning_; }
  [[nodiscard]] const std::string& sensors_if() const { return sensors_if_; }
  [[nodiscard]] const std::string& pu_sensor_if() const { return pu_sensor_if_; }
  [[nodiscard]] const std::string& pu_vehicle_if() const { return pu_vehicle_if_; }
  [[nodiscard]] const std::string& planning_if() const { return planning_if_; }

  // argv run inside namespace `ns`, for ChildProcess (execve: env finds `ip` on PATH; env and
  // ip netns exec both exec, so the pid is the program's own).
  static std::vector<std::string> in_namespace(const std::string& ns, std::vector<std::string> argv) {
    argv.insert(argv.begin(), {"/usr/bin/env", "ip", "netns", "exec", ns});
    return argv;
  }

 private:
  static std::string in(const std::string& ns) { return "ip netns exec " + ns + " "; }
  static bool run(const std::string& cmd) { return std::system((cmd + " >/dev/null 2>&1").c_str()) == 0; }
  static bool link(const std::string& ns_a, const std::string& if_a, const char* addr_a, const std::string& ns_b,
                   const std::string& if_b, const char* addr_b) {
    return run("ip link add " + if_a + " netns " + ns_a + " type veth peer name " + if_b + " netns " + ns_b) &&
           run(in(ns_a) + "ip addr add " + addr_a + "/24 dev " + if_a) &&
           run(in(ns_b) + "ip addr add " + addr_b + "/24 dev " + if_b) &&
           run(in(ns_a) + "ip link set " + if_a + " up") && run(in(ns_b) + "ip link set " + if_b + " up");
  }

  std::string sensors_, pu_, planning_, sensors_if_, pu_sensor_if_, pu_vehicle_if_, planning_if_, error_;
  std::vector<std::string> created_;
};

}  // namespace sensor_rig::test
