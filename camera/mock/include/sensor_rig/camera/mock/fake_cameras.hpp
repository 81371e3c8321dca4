#pragma once
// Aravis fakes for tests and the mock rig.
// - In process: "fake:<serial>" devices (arv_fake_device_new) — cheap, many per process, the
//   real AravisSource and stream code, no network.
// - GigE: one `arv-fake-gv-camera-0.8 -i <address>` process per loopback address (GVCP port 3956
//   is per address), the real network path; its 127.0.0.x address is a LoopbackAddress lease
//   (common/loopback_address.hpp: added to `lo` where permitted, removed when the last holder ends).
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "sensor_rig/camera/aravis_source.hpp"
#include "sensor_rig/camera/mock/camera_chaos.hpp"
#include "sensor_rig/common/child_process.hpp"

namespace sensor_rig::camera::mock {

inline constexpr const char* kFakePrefix = "fake:";
// rig-fake-gige-camera's software-trigger grid (Aravis's default is 25 Hz: a triggered frame was
// exposed up to 40 ms after its trigger): a pending trigger fires at the next 250 us step.
inline constexpr double kTriggerGridHz = 4000;
// GigE fake that exposes on the trigger (camera/mock/tools/rig_fake_gige_camera.cpp), built beside `rig`.
inline constexpr const char* kTriggerFollowingFake = "rig-fake-gige-camera";

// Opens "fake:<serial>" in process, anything else through the network. Aravis 0.8.26's in-process
// fake ignores TriggerSoftware (arvfakestream.c: a frame at every step of its trigger grid in
// trigger mode), so its grid is left at 25 Hz: a finer one would only stream faster.
// `chaos.truth` set (rig chaos): each frame the fake makes is written to that truth record (unit =
// frame id, acq = its timestamp, the exposure start; camera/README.md "Mocks: faults"); the fake
// takes no faults. Throws std::runtime_error when the truth file cannot be created.
AravisDeviceOpener inprocess_fake_opener(const ChaosArgs& chaos = {});


struct GigeFakeOptions {
  std::string address = "127.0.0.2";
  std::string serial;                  // default: derived from the address
  int lost_packets_per_thousand = 0;   // arv-fake-gv-camera -r: GVSP packet loss
  std::string genicam;                 // -g: a GenICam XML file instead of the built-in one
  std::string program = "arv-fake-gv-camera-0.8";  // or a path to kTriggerFollowingFake (same options)
  // kTriggerFollowingFake only: its threads SCHED_FIFO at this priority (0 = normal), so the mock's
  // trigger -> exposure is the camera's, as in hardware, not the host's scheduling of the mock.
  int realtime_priority = 0;
  // kTriggerFollowingFake only: --fault-plan / --device / --truth (camera_chaos.hpp), each when set.
  ChaosArgs chaos;
};

// A GigE Vision device's serial register holds 16 bytes with the NUL; Aravis' fakes refuse longer.
inline constexpr std::size_t kGigeSerialCapacity = 16;
// The serial of a fake on `address` when none is given: "RIG" and the IPv4 address in hex (11
// characters); throws std::runtime_error for an address that is not IPv4.
std::string gige_fake_serial(const std::string& address);
// argv of the fake process.
std::vector<std::string> gige_fake_command(const GigeFakeOptions& o);
// Starts the fake and waits (bounded) until its GVCP port answers; throws std::runtime_error.
ChildProcess start_gige_fake(const GigeFakeOptions& o, std::chrono::milliseconds timeout = std::chrono::seconds(3));
// The GenICam XML a device serves (opened through the network, as AravisSource does); throws
// CameraError. Tests derive variants of the fake's own XML from it (e.g. PTP features).
std::string device_genicam_xml(const std::string& device);
// A GenICam file for `arv-fake-gv-camera -g`: the fake's own XML (from a default fake started
// on `address` for the moment) plus PTP features on a free register of its memory: PtpEnable
// (Boolean on register PtpTestRegister at 0x8000: true sets bit 0 and keeps bits 8..31, false
// clears it) and PtpStatus (Enumeration computed from that register: 0 Disabled, 1 Slave,
// 2 Listening, any other value Faulty — so 0x100 before the enable is a servo faulty after it
// until disabled and enabled again), PtpDataSetLatch (Command: 1 into PtpLatchTestRegister at
// 0x8004). `gev_ieee1588`: the older names GevIEEE1588, GevIEEE1588Status and
// GevIEEE1588DataSetLatch instead. Returns the path of a new temporary file (the caller removes it);
// throws std::runtime_error / CameraError.
std::string write_ptp_fake_genicam(const std::string& address, bool gev_ieee1588 = false);
// The chaos PTP features (rig-fake-gige-camera under a camera.ptp fault): PtpEnable (Boolean on
// kChaosPtpEnableRegister, what the rig writes), PtpStatus (Enumeration of the SFNC values 0..6,
// Initializing..Uncalibrated, read from kChaosPtpStatusRegister, which the fake itself keeps as
// its PTP state machine says), PtpDataSetLatch (Command on kChaosPtpLatchRegister); `gev_ieee1588`:
// GevIEEE1588, GevIEEE1588Status and GevIEEE1588DataSetLatch instead. Built on the in-process
// fake's own XML (no network). Returns the XML.
inline constexpr std::uint32_t kChaosPtpEnableRegister = 0x8000;
inline constexpr std::uint32_t kChaosPtpLatchRegister = 0x8004;
inline constexpr std::uint32_t kChaosPtpStatusRegister = 0x8008;
std::string chaos_ptp_genicam_xml(bool gev_ieee1588 = false);
// The in-process fake's own GenICam XML (no network).
std::string fake_camera_genicam_xml();
// Chunk data and row padding (rig-fake-gige-camera, always): ChunkModeActive (Boolean on
// kChaosChunkModeRegister, what the rig writes through `features:`), ChunkTimestamp (IntReg, 8 bytes)
// and ChunkExposureTime (FloatReg, 8 bytes, us) on chunk ports kChaosChunkIdTimestamp /
// kChaosChunkIdExposure, and a PayloadSize that counts what the fake may send beside the image:
// Height x kChaosRowPaddingRegister (the widest camera.padded_rows of its plan) and
// kChaosChunkTrailerBytes when ChunkModeActive or kChaosChunkPlanRegister (a camera.chunk_data in
// its plan) is set, as a real camera's PayloadSize counts its padding and chunks. Takes and returns
// an XML; throws std::runtime_error when the fake's PayloadSize is not the one this extends.
inline constexpr std::uint32_t kChaosChunkModeRegister = 0x800c;
inline constexpr std::uint32_t kChaosRowPaddingRegister = 0x8010;
inline constexpr std::uint32_t kChaosChunkPlanRegister = 0x8014;
inline constexpr std::uint32_t kChaosChunkIdImage = 0xA0000001;
inline constexpr std::uint32_t kChaosChunkIdTimestamp = 0xA0000002;
inline constexpr std::uint32_t kChaosChunkIdExposure = 0xA0000003;
inline constexpr std::size_t kChaosChunkTrailerBytes = 8 + 16 + 16;  // image tag, timestamp, exposure
std::string chaos_chunk_genicam_xml(std::string xml);
// The fake's own XML plus TriggerSource entry Line1 (the fake has only Line0 and Software; in a
// line mode it sends no frame at all), TriggerActivation entry FallingEdge, and
// TriggerSoftwareTestRegister: a readable view of its write-only TriggerSoftware register (0x30c,
// set by a TriggerSoftware command and cleared only when the fake fires on it in software mode).
std::string write_line_trigger_fake_genicam(const std::string& address);
// True when something listens on UDP <address>:3956 (from /proc/net/udp).
bool gvcp_port_bound(const std::string& address);

}  // namespace sensor_rig::camera::mock
