// rig-fake-gige-camera: the Aravis GigE fake (ArvGvFakeCamera, the same device as
// arv-fake-gv-camera-0.8 over the real GVCP/GVSP path, same -i/-s/-g/-r options) that exposes a
// software-triggered frame right after the trigger instead of on its own 40 ms grid.
//
// Why: Aravis 0.8.26's fake fires a pending software trigger only at the next multiple of
// 1/trigger_frequency of CLOCK_REALTIME (arvfakecamera.c get_sleep_time_for_next_frame, default
// 25 Hz), so a LIDAR-triggered camera's exposure lands 0-40 ms after the trigger call. A finer grid
// alone makes its stream thread spin: arvgvfakecamera.c _thread polls with the remaining time
// truncated to whole ms, i.e. g_poll(..., 0) in a loop for the last ms before every grid point.
// So this process also provides g_poll (it interposes the one libaravis calls; same behaviour as
// GLib's: poll(2)) and, for the fake's zero-timeout polls in software trigger mode, blocks until a
// control packet (the TriggerSoftware write) arrives, or sleeps to the grid point when a trigger is
// pending: exposure follows the trigger within ~one grid step (1/kTriggerGridHz), no spinning.
// Free-running, those polls sleep to the next frame instead of spinning its last ms (as the stock
// fake does).
// Timing as a real camera's: the stock fake stamps a frame (g_get_real_time, the leader's timestamp)
// and sends it after its slow pattern generator, never waiting for the exposure, while a real
// camera's leader leaves after exposure + readout, which is what the rig's clock mapping assumes
// (first packet = exposure start + exposure time). So the fill callback here copies a precomputed
// ramp (memcpy, shifted per frame), then waits until stamp + ExposureTime: the leader leaves at
// exposure end (a free-running frame whose thread was held off its core is restamped by its
// lateness; a triggered one's exposure starts at its trigger's kernel receive time: expose_then_fill).
// And the leader goes out alone (a pause after it), so that its receiver takes it before the data
// (gige_fake_chaos pace(); --link-mbps paces every packet at a link's rate).
#include <arv.h>
#include <poll.h>
#include <pthread.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <limits>
#include <string>
#include <vector>

#include "gige_fake_chaos.hpp"
#include "sensor_rig/camera/mock/fake_cameras.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/thread_priority.hpp"

namespace {

std::atomic<ArvFakeCamera*> g_camera{nullptr};  // set once the fake runs; read by g_poll
volatile std::sig_atomic_t g_stop = 0;
double g_grid_hz = sensor_rig::camera::mock::kTriggerGridHz;
constexpr int kIdleWaitMs = 100;  // the fake's own longest poll

// The kernel's receive time (CLOCK_REALTIME) of the latest TriggerSoftware write that came in, 0
// once a frame took it: a triggered frame's exposure starts there, as a camera's does on the
// trigger's arrival (hardware: microseconds), however late this process's threads ran after it.
std::atomic<sensor_rig::Nanos> g_trigger_rx_ns{0};
// A trigger older than this took no frame (refused, or its frame lost): never a later frame's start.
constexpr sensor_rig::Nanos kTriggerRxValidNs = 500'000'000;

void on_signal(int) { g_stop = 1; }

// A diagonal ramp (as the stock fake's, but computed once): a frame is a copy from a per-frame offset.
struct Pattern {
  static constexpr std::size_t kShifts = 256;
  std::vector<guint8> ramp;
  void fill(ArvBuffer* buffer, std::size_t payload) {
    if (ramp.size() < payload + kShifts) {
      ramp.resize(payload + kShifts);
      for (std::size_t i = 0; i < ramp.size(); ++i) ramp[i] = static_cast<guint8>(i % 251);
    }
    // The fake sends its buffer's data (payload bytes, allocated for it); get_data's size is unset here.
    auto* data = static_cast<guint8*>(const_cast<void*>(arv_buffer_get_data(buffer, nullptr)));
    std::memcpy(data, ramp.data() + arv_buffer_get_frame_id(buffer) % kShifts, payload);
  }
};

struct FillContext {
  ArvFakeCamera* camera = nullptr;
  sensor_rig::camera::mock::GigeFakeChaos* chaos = nullptr;
  Pattern pattern;
};

// Runs in arv_fake_camera_fill_buffer after the frame's id is set, before the leader is sent: the
// exposure starts now; a software-triggered frame's started when its trigger arrived
// (g_trigger_rx_ns), as a camera's does, however late this thread ran after it (a fake held off its
// core stamped a triggered frame "exposed 61 ms after the rig's trigger", a fresh-clone suite run's
// CameraIsolation.AStreamsFirstFrameIsExposedAtItsTrigger). Its stamp is the host's CLOCK_REALTIME
// (the truth's acq, what the leader says; this process's g_get_real_time, which Aravis stamped it
// with, is a clock that a host clock step does not move: below). Chaos may change the exposure and
// what the camera reports as its timestamp (PTP). The image is copied first (the fake's cost, not the
// camera's timing), then the thread waits for the exposure's end, on CLOCK_MONOTONIC from its start
// (it waited until stamp + exposure by CLOCK_REALTIME: a host step back between the two held the
// frame, and its camera, that much longer). A free-running frame whose thread got there late (a
// loaded host held it off its core: 1.5 ms p50 in the whole-rig campaign, up to 4 ms) is restamped
// by that much: the exposure began later, and the leader still leaves at the end of the exposure the
// camera reports, as a camera's does and the rig's clock mapping takes it (issue 27: otherwise the
// mapping carries the fake's lateness as a bias the truth does not have).
void expose_then_fill(ArvBuffer* buffer, void* data, guint32 exposure_time_us, guint32 /*gain*/, ArvPixelFormat /*format*/) {
  auto* ctx = static_cast<FillContext*>(data);
  const auto now = sensor_rig::clock_pair_now();  // one instant: the leader leaves exposure after `start` exactly
  sensor_rig::Nanos start_mono = now.monotonic_ns;
  sensor_rig::Nanos start = now.vehicle_ns;
  const sensor_rig::Nanos trigger_rx = g_trigger_rx_ns.exchange(0);
  const bool at_trigger = arv_fake_camera_is_in_software_trigger_mode(ctx->camera) && trigger_rx > 0 &&
                          trigger_rx <= start && start - trigger_rx < kTriggerRxValidNs;
  if (at_trigger) {
    start_mono -= start - trigger_rx;
    start = trigger_rx;
  }
  arv_buffer_set_timestamp(buffer, static_cast<guint64>(start));
  const guint32 exposure_us = ctx->chaos->on_fill(ctx->camera, buffer, exposure_time_us);
  ctx->pattern.fill(buffer, arv_fake_camera_get_payload(ctx->camera));
  const sensor_rig::Nanos end_mono = start_mono + sensor_rig::Nanos{exposure_us} * 1000;
  const timespec until{static_cast<time_t>(end_mono / 1'000'000'000), static_cast<long>(end_mono % 1'000'000'000)};
  while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, nullptr) == EINTR) {
  }
  // A triggered exposure began at its trigger: a late thread only delays the readout.
  if (!at_trigger) ctx->chaos->restamp(buffer, sensor_rig::monotonic_now_ns() - end_mono);
}

// Each socket the fake polls gets its datagrams' kernel receive times (SO_TIMESTAMPNS; set on every
// call: a restarted fake's new sockets may reuse the numbers). Non-sockets refuse it, harmlessly.
void stamp_datagrams(const pollfd* pfds, nfds_t nfds) {
  const int on = 1;
  for (nfds_t i = 0; i < nfds; ++i) ::setsockopt(pfds[i].fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on);
}

// Before the fake reads them: a readable socket's next datagram, peeked, is it a GVCP
// WRITEREG_CMD with TriggerSoftware among its (address, value) pairs? Then its receive time is
// the trigger's. (A write the fake then ignores, from a connection that is not its controller or
// outside acquisition, is overwritten by the next trigger's before any frame takes it.)
void note_trigger_writes(const pollfd* pfds, nfds_t nfds) {
  for (nfds_t i = 0; i < nfds; ++i) {
    if ((pfds[i].revents & POLLIN) == 0) continue;
    std::uint8_t packet[8 + 8 * 16];
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec))];
    iovec iov{packet, sizeof packet};
    msghdr msg{};
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control;
    msg.msg_controllen = sizeof control;
    const ssize_t n = ::recvmsg(pfds[i].fd, &msg, MSG_PEEK | MSG_DONTWAIT);
    // GVCP command header: 0x42, flags, command (big endian), length, request id.
    if (n < 16 || packet[0] != 0x42 || packet[2] != 0x00 || packet[3] != 0x82) continue;
    bool trigger = false;
    for (ssize_t at = 8; at + 8 <= n; at += 8) {
      const std::uint32_t address = (std::uint32_t{packet[at]} << 24) | (std::uint32_t{packet[at + 1]} << 16) |
                                    (std::uint32_t{packet[at + 2]} << 8) | packet[at + 3];
      const bool nonzero = (packet[at + 4] | packet[at + 5] | packet[at + 6] | packet[at + 7]) != 0;
      trigger = trigger || (address == ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOFTWARE && nonzero);
    }
    if (!trigger) continue;
    sensor_rig::Nanos rx = 0;
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c))
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
        timespec ts{};
        std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
        rx = sensor_rig::Nanos{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
      }
    g_trigger_rx_ns.store(rx > 0 ? rx : sensor_rig::vehicle_now_ns());
  }
}

// poll(2) as GLib's g_poll, noting the trigger writes among what came in.
int poll_noting_triggers(pollfd* pfds, nfds_t nfds, const timespec* wait) {
  stamp_datagrams(pfds, nfds);
  const int n = ::ppoll(pfds, nfds, wait, nullptr);
  if (n > 0) note_trigger_writes(pfds, nfds);
  return n;
}

int poll_noting_triggers(pollfd* pfds, nfds_t nfds, int timeout_ms) {
  if (timeout_ms < 0) return poll_noting_triggers(pfds, nfds, nullptr);
  const timespec wait{timeout_ms / 1000, static_cast<long>(timeout_ms % 1000) * 1'000'000};
  return poll_noting_triggers(pfds, nfds, &wait);
}

bool trigger_pending(ArvFakeCamera* cam) {
  guint32 value = 0;
  return arv_fake_camera_read_register(cam, ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOFTWARE, &value) && value != 0;
}

// Until the fake's next grid point: where it fires a pending trigger, or sends a free-running
// frame (the fake's loop polls only before its next point, so this never sleeps past it).
timespec until_next_grid_point(ArvFakeCamera* cam, bool triggered) {
  guint32 frame_period_us = 0;
  if (!triggered) arv_fake_camera_read_register(cam, ARV_FAKE_CAMERA_REGISTER_ACQUISITION_FRAME_PERIOD_US, &frame_period_us);
  const gint64 period_us = triggered ? static_cast<gint64>(1e6 / g_grid_hz) : frame_period_us;
  if (period_us <= 0) return {0, 0};
  const gint64 left_us = period_us - g_get_real_time() % period_us;
  return {0, static_cast<long>(left_us * 1000)};
}

int usage(const char* self, int status) {
  std::fprintf(status == 0 ? stdout : stderr,
               "usage: %s -i ADDRESS [-s SERIAL] [-g GENICAM.xml] [-r LOST_PER_THOUSAND] [--trigger-hz HZ]\n"
               "          [--realtime-priority N] [--link-mbps MBPS] [--fault-plan FILE] [--device NAME] [--truth FILE]\n"
               "          [--gev-ieee1588]\n"
               "Aravis GigE fake camera (as arv-fake-gv-camera-0.8) whose software-triggered frames are exposed\n"
               "within ~1/HZ of the trigger (default %.0f Hz) without a busy loop. --realtime-priority: every\n"
               "thread SCHED_FIFO N where permitted (a warning if not). --link-mbps: the stream's packets leave at\n"
               "this link rate (default 0: as fast as sent; the leader always alone first). --fault-plan/--device: the camera.* faults of\n"
               "that camera (default: RIG_CHAOS_DIR's plan when --device is given); --truth: its truth record (default\n"
               "RIG_CHAOS_DIR/truth/NAME.jsonl); --gev-ieee1588: PTP features by their GevIEEE1588 names. Stops on\n"
               "SIGINT/SIGTERM.\n",
               self, sensor_rig::camera::mock::kTriggerGridHz);
  return status;
}

}  // namespace

// Set by g_poll on the fake's thread: its next g_get_real_time call (the check that ends the loop's
// poll window) is told the window is over.
thread_local bool t_end_window = false;

// libaravis's fake stream thread calls g_poll through the PLT: this definition is the one it gets.
extern "C" gint g_poll(GPollFD* fds, guint nfds, gint timeout) {
  static_assert(sizeof(GPollFD) == sizeof(pollfd));
  auto* pfds = reinterpret_cast<pollfd*>(fds);
  ArvFakeCamera* cam = g_camera.load(std::memory_order_acquire);
  // Until it has sent its first frame the stock loop polls in windows of 100 ms that end only by
  // the clock, and fires a trigger at a window's end: a stream's first frame came 0-100 ms after
  // its trigger (the rig stamped it with that tick: the whole-rig campaign's stereo frame 41 ms
  // "early" after a camera.slow_open reboot). A pending trigger of an acquiring camera ends the
  // window now, as a camera exposes on its trigger.
  // A trigger outside acquisition is ignored (SFNC's acquisition model), not kept for its start:
  // Aravis retries a write through a camera.slow_open's silence, and the rebooted camera got the
  // previous connection's TriggerSoftware and fired it as the new stream began.
  if (cam != nullptr && arv_fake_camera_get_acquisition_status(cam) == 0 && trigger_pending(cam))
    arv_fake_camera_write_register(cam, ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOFTWARE, 0);
  if (timeout > 0 && cam != nullptr && arv_fake_camera_get_acquisition_status(cam) != 0 &&
      arv_fake_camera_is_in_software_trigger_mode(cam) && trigger_pending(cam)) {
    t_end_window = true;
    return 0;
  }
  if (cam == nullptr) return ::poll(pfds, nfds, timeout);
  if (timeout != 0) return poll_noting_triggers(pfds, nfds, timeout);
  const bool triggered = arv_fake_camera_is_in_software_trigger_mode(cam);
  if (triggered && !trigger_pending(cam)) return poll_noting_triggers(pfds, nfds, kIdleWaitMs);  // woken by the trigger's packet
  const timespec wait = until_next_grid_point(cam, triggered);
  return poll_noting_triggers(pfds, nfds, &wait);
}

// The clock of the camera's own timing: CLOCK_REALTIME when the process started, then CLOCK_MONOTONIC.
// Aravis' fake times everything on g_get_real_time: its stream loop's frame instants and poll
// windows (until g_get_real_time() passes the next frame's time), its frame grid, the controller's
// heartbeat. On the host's CLOCK_REALTIME a step back (host.clock_step, an NTP/PTP servo's step)
// held the stream loop for the step's length, every frame of it unsent, and a step forward beyond
// the heartbeat timeout (3 s) took the controller's privilege away: the stream stopped for good. A
// camera's timing runs on its own oscillator, which a host's clock step does not touch. The frames'
// stamps stay the host's CLOCK_REALTIME (expose_then_fill). Free-running fakes started together
// still expose on one instant (their offsets agree to microseconds).
// The loop's window check after g_poll ended a window (above): past it. Every other call: the
// camera's clock.
extern "C" gint64 g_get_real_time() {
  if (t_end_window) {
    t_end_window = false;
    return std::numeric_limits<gint64>::max() / 2;
  }
  static const sensor_rig::Nanos camera_clock_offset_ns = sensor_rig::clock_pair_now().vehicle_minus_monotonic();
  return (sensor_rig::monotonic_now_ns() + camera_clock_offset_ns) / 1000;
}

namespace {

// A GenICam file for the fake's construction (it reads the file then): written, used, removed at once.
class TemporaryFile {
 public:
  explicit TemporaryFile(const std::string& text) {
    char path[] = "/tmp/rig_fake_genicam_XXXXXX.xml";
    const int fd = ::mkstemps(path, 4);
    if (fd < 0) throw std::runtime_error(std::string("mkstemps: ") + std::strerror(errno));
    ::close(fd);
    path_ = path;
    std::ofstream out(path_);
    out << text;
    if (!out.flush()) throw std::runtime_error("cannot write " + path_);
  }
  ~TemporaryFile() { ::unlink(path_.c_str()); }
  TemporaryFile(const TemporaryFile&) = delete;
  TemporaryFile& operator=(const TemporaryFile&) = delete;
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  std::string path_;
};

struct Fake {
  std::string address, serial, genicam, genicam_xml;  // genicam_xml: the chaos PTP features, else empty
  FillContext fill;
  ArvGvFakeCamera* gv = nullptr;

  bool start() {
    std::unique_ptr<TemporaryFile> xml;
    if (genicam.empty() && !genicam_xml.empty()) xml = std::make_unique<TemporaryFile>(genicam_xml);
    const std::string file = xml ? xml->path() : genicam;
    gv = arv_gv_fake_camera_new_full(address.c_str(), serial.empty() ? nullptr : serial.c_str(), file.empty() ? nullptr : file.c_str());
    if (gv == nullptr || !arv_gv_fake_camera_is_running(gv)) {
      if (gv != nullptr) g_object_unref(gv);
      gv = nullptr;
      return false;
    }
    // Random loss (-r) is applied, and recorded, by the chaos send hook: which packet of which frame.
    g_object_set(gv, "gvsp-lost-ratio", 0.0, nullptr);
    ArvFakeCamera* cam = arv_gv_fake_camera_get_fake_camera(gv);
    arv_fake_camera_set_trigger_frequency(cam, g_grid_hz);
    fill.camera = cam;
    fill.chaos->booted(cam);
    arv_fake_camera_set_fill_pattern(cam, expose_then_fill, &fill);
    sensor_rig::camera::mock::set_gige_fake_camera(cam);
    g_camera.store(cam, std::memory_order_release);
    return true;
  }
  void stop() {
    g_camera.store(nullptr, std::memory_order_release);
    sensor_rig::camera::mock::set_gige_fake_camera(nullptr);
    if (gv != nullptr) g_object_unref(gv);  // joins its thread
    gv = nullptr;
  }
};

}  // namespace

int main(int argc, char** argv) {
  namespace mock = sensor_rig::camera::mock;
  std::string address, serial, genicam;
  mock::ChaosArgs chaos_args;
  bool gev_ieee1588 = false;
  double lost_per_thousand = 0;
  double link_mbps = 0;
  int realtime_priority = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") return usage(argv[0], 0);
    if (a == "--gev-ieee1588") {
      gev_ieee1588 = true;
      continue;
    }
    if (i + 1 >= argc) return usage(argv[0], 2);
    const char* v = argv[++i];
    if (a == "-i" || a == "--interface") address = v;
    else if (a == "-s" || a == "--serial") serial = v;
    else if (a == "-g" || a == "--genicam") genicam = v;
    else if (a == "-r" || a == "--gvsp-lost-ratio") lost_per_thousand = std::atof(v);
    else if (a == "--trigger-hz") g_grid_hz = std::atof(v);
    else if (a == "--realtime-priority") realtime_priority = std::atoi(v);
    else if (a == "--link-mbps") link_mbps = std::atof(v);
    else if (a == "--fault-plan") chaos_args.plan = v;
    else if (a == "--device") chaos_args.device = v;
    else if (a == "--truth") chaos_args.truth = v;
    else {
      std::fprintf(stderr, "rig-fake-gige-camera: unknown option %s\n", a.c_str());
      return usage(argv[0], 2);
    }
  }
  if (address.empty() || !(g_grid_hz >= 1 && g_grid_hz <= 1e6) || lost_per_thousand < 0 || realtime_priority < 0 ||
      realtime_priority > 99 || !(link_mbps >= 0 && link_mbps <= 100'000))
    return usage(argv[0], 2);
  // Aravis refuses a serial of 16 characters or more (the GigE Vision register holds 16 with its
  // NUL) and then runs the GVCP thread on no camera at all: every read "assertion
  // 'ARV_IS_FAKE_CAMERA (camera)' failed", a device that answers and never streams.
  if (serial.size() >= mock::kGigeSerialCapacity) {
    std::fprintf(stderr, "rig-fake-gige-camera: serial '%s' is %zu characters; at most %zu\n", serial.c_str(), serial.size(),
                 mock::kGigeSerialCapacity - 1);
    return 2;
  }
  if (!chaos_args.device.empty()) {  // a campaign's folder names what was not given
    const auto env = mock::chaos_from_env(chaos_args.device);
    if (chaos_args.plan.empty()) chaos_args.plan = env.plan;
    if (chaos_args.truth.empty()) chaos_args.truth = env.truth;
  }
  std::unique_ptr<mock::GigeFakeChaos> chaos;
  Fake fake;
  try {
    chaos = std::make_unique<mock::GigeFakeChaos>(mock::GigeFakeChaos::Options{chaos_args, lost_per_thousand, link_mbps});
    // Chunk mode and row padding always (ChunkModeActive through the rig's features:, the
    // camera.chunk_data / camera.padded_rows faults); PTP features only under camera.ptp.
    fake.genicam_xml = mock::chaos_chunk_genicam_xml(chaos->needs_ptp_features() ? mock::chaos_ptp_genicam_xml(gev_ieee1588)
                                                                                 : mock::fake_camera_genicam_xml());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rig-fake-gige-camera: %s\n", e.what());
    return 2;
  }
  // Before the fake starts its threads: they inherit the policy. A hardware camera's trigger ->
  // exposure does not depend on the host's load; a mock at normal priority on a busy host would.
  if (realtime_priority > 0)
    if (const auto r = sensor_rig::try_realtime_priority(realtime_priority); !r)
      std::fprintf(stderr, "rig-fake-gige-camera: --realtime-priority %d not applied (%s): normal threads\n",
                   realtime_priority, r.why_not.c_str());
  // The default 50 us timer slack would be a fifth of a 250 us grid step (inherited by the fake's thread).
  ::prctl(PR_SET_TIMERSLACK, 1UL);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  fake.address = address;
  fake.serial = serial;
  fake.genicam = genicam;
  fake.fill.chaos = chaos.get();
  mock::set_gige_fake_chaos(chaos.get());
  chaos->tick();  // faults due at start (slow open, dead) hold before the first request is answered
  if (!fake.start()) {
    std::fprintf(stderr, "rig-fake-gige-camera: failed to start on %s\n", address.c_str());
    mock::set_gige_fake_chaos(nullptr);
    return 1;
  }
  // Every 10 ms: faults begin and end on time (a dead camera returns as from a power cycle).
  while (g_stop == 0) {
    g_usleep(10'000);
    if (chaos->tick()) {
      fake.stop();
      if (!fake.start()) {
        std::fprintf(stderr, "rig-fake-gige-camera: failed to restart on %s\n", address.c_str());
        break;
      }
    }
  }
  fake.stop();
  mock::set_gige_fake_chaos(nullptr);
  chaos->finish();
  return 0;
}
