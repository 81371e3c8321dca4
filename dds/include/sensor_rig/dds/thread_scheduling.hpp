#pragma once
// Cyclone's own threads under SCHED_FIFO: on a busy 2-core PU a cloud's datagrams wait in the
// socket until the receive thread is scheduled, and the reader's wake-up waits behind every
// normal thread (dds/README.md "The receive path under load").
#include <string>

namespace sensor_rig::dds {

// The Cyclone threads that carry a sample: the receive thread (which also delivers, synchronously,
// to local readers), the delivery queue for user data, and the timed events (heartbeats, acks).
// Cyclone 0.10 cannot name its extra per-socket receive threads (recvUC, recvMC: "unknown thread"),
// so the fragment also turns them off (Internal/MultipleReceiveThreads false): one "recv" thread
// serves every socket.
inline constexpr const char* kRealtimeThreadNames[] = {"recv", "dq.user", "tev"};

// A Cyclone XML fragment (for the configuration list) giving those threads SCHED_FIFO at
// `priority`, or "" when priority <= 0 or the process may not use it: Cyclone fails the domain
// when it cannot create a thread with the class it was given. `refused` says why when refused.
std::string realtime_threads_fragment(int priority, std::string* refused = nullptr);

}  // namespace sensor_rig::dds
