// rig.dds.realtime_priority: Cyclone's receive, user-delivery and timed-event threads run
// SCHED_FIFO at that priority where permitted (the others keep normal scheduling); where refused,
// the participant still comes up, with normal threads.
#include <dirent.h>
#include <gtest/gtest.h>
#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>

#include <fstream>
#include <map>
#include <string>

#include "dds_domain_lease.hpp"
#include "sensor_rig/dds/participant.hpp"
#include "sensor_rig/dds/thread_scheduling.hpp"
#include "sensor_rig/dds/types.hpp"

namespace sensor_rig::dds {
namespace {

// Thread name -> "FIFO <prio>" or "OTHER" for every thread of this process.
std::multimap<std::string, std::string> thread_policies() {
  std::multimap<std::string, std::string> out;
  DIR* d = ::opendir("/proc/self/task");
  if (d == nullptr) return out;
  while (const dirent* e = ::readdir(d)) {
    if (e->d_name[0] == '.') continue;
    std::string comm;
    std::getline(std::ifstream(std::string("/proc/self/task/") + e->d_name + "/comm"), comm);
    const pid_t tid = static_cast<pid_t>(std::stoi(e->d_name));
    sched_param sp{};
    const int policy = ::sched_getscheduler(tid);
    ::sched_getparam(tid, &sp);
    out.emplace(comm, policy == SCHED_FIFO ? "FIFO " + std::to_string(sp.sched_priority) : "OTHER");
  }
  ::closedir(d);
  return out;
}

bool may_use_rtprio() {
  rlimit rl{};
  return ::geteuid() == 0 || (::getrlimit(RLIMIT_RTPRIO, &rl) == 0 && rl.rlim_cur >= 13);
}

TEST(DdsThreadScheduling, ReceiveDeliveryAndEventThreadsRunFifoWherePermitted) {
  DomainConfig cfg;
  cfg.domain_id = static_cast<dds_domainid_t>(sensor_rig::test::lease_dds_domain());  // a fresh Cyclone of its own
  cfg.realtime_priority = 13;
  Participant p(cfg);
  QosSpec q;
  Topic<msg::PointCloud2> topic(p, "/test/thread_scheduling/points", q);
  Reader<msg::PointCloud2> reader(p, topic, q);  // a reader: Cyclone starts its user delivery queue
  Writer<msg::PointCloud2> writer(p, topic, q);
  const auto threads = thread_policies();
  const bool permitted = may_use_rtprio();
  int named = 0;
  for (const char* name : kRealtimeThreadNames) {
    for (auto [it, end] = threads.equal_range(name); it != end; ++it, ++named)
      EXPECT_EQ(it->second, permitted ? "FIFO 13" : "OTHER") << name;
  }
  EXPECT_GE(named, 2) << "no receive / event thread found by name";  // tev and at least one recv
  for (auto [it, end] = threads.equal_range("gc"); it != end; ++it) EXPECT_EQ(it->second, "OTHER");
  if (permitted) {  // data arrives on recvUC in Cyclone's default: it must not exist at normal priority
    EXPECT_EQ(threads.count("recvUC"), 0u);
    EXPECT_EQ(threads.count("recvMC"), 0u);
  }
  EXPECT_EQ(realtime_threads_fragment(0), "");
}

}  // namespace
}  // namespace sensor_rig::dds
