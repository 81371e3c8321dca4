#pragma once
// A camera as a frame source: open (throws CameraError with the reason), next(timeout) -> a value
// (frame, timeout, incomplete, disconnected: never an exception in the capture loop), close.
// One thread uses a source; a Frame must be dropped before the next call to next() or close().
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "sensor_rig/camera/frame.hpp"
#include "sensor_rig/camera/pixel_format.hpp"

namespace sensor_rig::camera {

struct CameraError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

enum class TriggerMode : std::uint8_t { kFreeRun = 0, kSoftware, kLine };
const char* to_string(TriggerMode m) noexcept;

// IEEE 1588 (PTP) on a GigE camera (aravis backend): PtpEnable (SFNC) or GevIEEE1588 (older).
// While the device reports Master/Slave its frame timestamps are PTP time (TAI, or UTC when
// `tai` is false) and frames carry TimeDomain::kVehicle (UTC); otherwise device ticks (mapped).
struct PtpConfig {
  bool enable = false;
  bool tai = true;                // the camera's timescale: TAI (PTP's own) or UTC
  int tai_utc_offset_s = 37;      // TAI - UTC (37 s since 2017)
  int status_poll_ms = 1000;      // status re-read period (own thread, never per frame)
  // Master is locked only for a camera meant to be the grandmaster: one that won the election
  // because the PU's ptp4l is down (another domain, VLAN) runs on its own clock.
  bool grandmaster = false;
};

// What a backend is asked to configure (the driver's config minus DDS). Applied in this order:
// pixel format, ROI, frame rate, exposure, gain, then `features` by name, then the trigger.
struct SourceConfig {
  std::string backend = "aravis";  // aravis | v4l2
  std::string device;              // aravis: id, serial, IP or MAC; v4l2: /dev/videoN
  PixelFormat format = PixelFormat::kBayerRG8;
  std::uint32_t width = 1920;
  std::uint32_t height = 1200;
  double frame_rate = 10.0;
  double exposure_us = 0.0;        // 0: leave as the device has it
  double gain_db = -1.0;           // < 0: leave as the device has it
  std::vector<std::pair<std::string, std::string>> features;  // any GenICam feature: name -> value
  TriggerMode trigger = TriggerMode::kFreeRun;
  std::string trigger_line = "Line1";  // kLine: TriggerSource (an I/O line, Line<N>)
  std::string trigger_activation = "RisingEdge";  // kLine: TriggerActivation (SFNC entry name)
  int packet_size = 0;                 // GigE: 0 = negotiate
  std::int64_t packet_delay_ns = 0;    // GigE inter-packet delay
  int socket_buffer_bytes = 8 << 20;   // GigE stream socket (fixed; >= 4 MB, SPEC §8)
  bool packet_socket = false;          // Aravis' packet socket: receives nothing from the fake as root
  int buffers = 4;                     // pool size
  PtpConfig ptp;                       // aravis only
  // V4L2 buffer timestamps: `auto` follows the buffer's flag (TSTAMP_SRC_EOF: end of frame, else
  // start of exposure); a driver that stamps elsewhere without saying so needs `start`/`end`.
  // An end-of-frame stamp lies exposure + readout after the exposure start: readout_us, 0 = half
  // the granted frame period (a rolling shutter reads out over most of a frame at 10-30 Hz).
  std::string v4l2_stamp = "auto";     // auto | start | end
  double readout_us = 0.0;
  // V4L2_CID_GAIN has no unit (each driver its own): gain_db is written as the control's minimum
  // (0 dB) + gain_db x this many units per dB; 0 = not given (gain_db is then refused on V4L2).
  double v4l2_gain_units_per_db = 0.0;
};

// The PTP state a source reports (diagnostics).
struct PtpState {
  bool enabled = false;           // configured and enabled on the device
  std::string enable_feature;     // PtpEnable | GevIEEE1588
  std::string status;             // the device's status text (Master, Slave, Faulty, ...)
  bool locked = false;            // Slave (or Master when grandmaster): frames carry PTP time
  std::uint64_t resets = 0;       // disable + enable after Faulty/Disabled/Initializing
  std::uint64_t polls = 0;        // status reads
  std::int64_t poll_max_us = 0;   // the slowest status read (a GVCP round trip)
  std::string error;              // the last failed status read / reset
};

enum class CaptureStatus : std::uint8_t {
  kFrame = 0,
  kTimeout,       // nothing within the timeout
  kIncomplete,    // a frame arrived damaged (missing packets, short buffer): counted, not returned
  kDisconnected,  // control lost / device gone: close() and open() again
  kError,         // other failure (reason in Capture::error)
};
const char* to_string(CaptureStatus s) noexcept;

struct Capture {
  CaptureStatus status = CaptureStatus::kTimeout;
  Frame frame;
  std::string error;
};

struct SourceStats {
  std::uint64_t completed = 0;   // frames returned
  std::uint64_t incomplete = 0;  // damaged frames dropped (failures, short buffers): the sum of
  std::uint64_t incomplete_timeout = 0;          //   the frame's packets stopped coming (frame retention)
  std::uint64_t incomplete_missing_packets = 0;  //   packets lost and not resent in time
  std::uint64_t incomplete_other = 0;            //   any other status, a wrong size or foreign memory
  std::uint64_t timeouts = 0;
  std::uint64_t underruns = 0;   // no free buffer when a frame started
  std::uint64_t missing_packets = 0;
  std::uint64_t resent_packets = 0;
  std::uint64_t disconnects = 0;
  // Frames the device made that never reached next(): GigE block-id gaps (underruns, frames Aravis
  // discarded), V4L2 sequence gaps, and the frames a close found waiting in the stream. GigE ids
  // are followed across a close and an open (a camera that goes on numbering: the gap is counted;
  // one that restarted: not); a V4L2 stream restarts its sequence at STREAMON.
  std::uint64_t missing_frames = 0;
  // Software triggers refused because another access to the camera (a GenICam read in a GVCP
  // timeout) held it past the trigger's wait: the trigger never queues behind it.
  std::uint64_t trigger_busy = 0;
  // GigE: the stream socket's SO_RCVBUF as the kernel granted it (capped by net.core.rmem_max) and
  // what one frame in flight needs; 0: not a UDP stream (issue 27 item 4).
  std::int64_t socket_buffer_granted = 0;
  std::int64_t socket_buffer_needed = 0;
  // GigE: the GVSP payload of the last frame returned ("image", "image+chunks", "chunk_data",
  // "extended_chunk_data", "multipart"; a static string); "" before the first or for another kind.
  const char* payload = "";
  // Every frame made and not returned: what the driver reports as `counted_lost`.
  [[nodiscard]] std::uint64_t lost_frames() const noexcept { return incomplete + missing_frames; }
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual void open() = 0;  // throws CameraError
  virtual void close() noexcept = 0;
  [[nodiscard]] virtual bool is_open() const noexcept = 0;
  virtual Capture next(int timeout_ms) = 0;
  // The caller's watchdog gave up on the device: close() must not wait for it to answer.
  virtual void mark_lost() noexcept {}
  // Software trigger (TriggerMode::kSoftware); false when not open, refused or in another mode.
  virtual bool trigger() { return false; }
  [[nodiscard]] virtual SourceStats stats() const = 0;
  // PTP state; enabled == false when the source has no PTP (V4L2, or not configured).
  [[nodiscard]] virtual PtpState ptp() const { return {}; }
  // The exposure time the device has since open (its ExposureTime read back), us; 0: unknown.
  [[nodiscard]] virtual double exposure_us() const { return 0.0; }
  [[nodiscard]] virtual std::string describe() const = 0;  // "aravis 127.0.0.2 BayerRG8 1920x1200@10"
};

}  // namespace sensor_rig::camera
