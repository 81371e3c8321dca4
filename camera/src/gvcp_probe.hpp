#pragma once
// Private to AravisSource: is a GigE camera at this IPv4 address answering GVCP at all? One
// READREG of the bootstrap Version register (0x0000: readable without control, changes nothing),
// on a socket of its own, with a short timeout and a few tries. Aravis' own open of a camera that
// does not answer spends ~2.5 s in GVCP retries and discovery (arv_open_device, under Aravis' system
// mutex and the rig's process-wide open lock: every other camera's open waited behind it, issue 27
// item 1); the probe costs its caller `tries` x `timeout_ms` and holds no lock. It also says which
// local address reaches the camera (the interface Aravis' device then binds), so the device is
// opened by address directly, without discovery.
#include <string>

namespace sensor_rig::camera::detail {

struct GvcpProbe {
  int tries = 3;         // READREG requests, each waited for timeout_ms
  int timeout_ms = 100;  // a live camera answers in well under a millisecond on a link
};

// The local IPv4 address (dotted) whose route reaches `address` when a READREG there was answered;
// throws CameraError naming the address and what happened (no answer, refused) otherwise.
std::string probe_gvcp(const std::string& address, const GvcpProbe& how = {});

// Whether the camera at `address` answers a READREG within the probe's tries (never throws).
bool answers_gvcp(const std::string& address, const GvcpProbe& how) noexcept;

// True when `device` is a dotted IPv4 address (opened by address: no discovery).
bool is_ipv4_address(const std::string& device) noexcept;

}  // namespace sensor_rig::camera::detail
