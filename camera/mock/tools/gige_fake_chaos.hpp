#pragma once
// rig-fake-gige-camera under a `rig chaos` campaign: the camera.* faults of one camera and its truth
// record (camera/README.md "Mocks: faults and truth"). The fake's own thread calls on_fill (a frame
// stamped, before its leader), on_send (every GVCP/GVSP datagram it sends) and on_receive (every
// datagram it got, before it handles it); the main thread calls tick() every few ms and reboots
// the fake when it returns true. This process interposes g_socket_send_to and
// g_socket_receive_message (as it does g_poll) to get those calls: a camera that is dead sends and
// answers nothing, and which packet of which frame was lost is known, not guessed.
#include <arv.h>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "sensor_rig/common/network_hold.hpp"

#include "gvsp_reshaper.hpp"
#include "sensor_rig/camera/mock/camera_chaos.hpp"

namespace sensor_rig::camera::mock {

class GigeFakeChaos {
 public:
  struct Options {
    ChaosArgs args;
    double lost_per_thousand = 0;  // -r: random GVSP loss, recorded (fate dropped, no fault)
    double link_mbps = 0;          // --link-mbps: the stream's packets leave at this rate (0: as fast as sent)
  };
  explicit GigeFakeChaos(const Options& o);  // throws std::runtime_error (plan, truth file)
  ~GigeFakeChaos();
  GigeFakeChaos(const GigeFakeChaos&) = delete;
  GigeFakeChaos& operator=(const GigeFakeChaos&) = delete;

  [[nodiscard]] bool needs_ptp_features() const { return schedule_.has("camera.ptp"); }
  // The fake (re)started: its registers are fresh, frame ids start again at 1.
  void booted(ArvFakeCamera* cam);
  // Main thread: begins and ends faults; true = reboot the fake now (a dead camera returns).
  bool tick();

  // The fake's thread. on_fill: returns the exposure to wait (us) and sets the reported stamp.
  std::uint32_t on_fill(ArvFakeCamera* cam, ArvBuffer* buffer, std::uint32_t exposure_us);
  // The fake's thread got to its exposure's end `late_ns` after it (held off a core): the exposure is
  // taken to have begun that much later, in the buffer's stamp, the chunk and the truth alike, so that
  // its leader still leaves at the end of the exposure it reports (a camera's does; the rig maps its
  // clock by that).
  void restamp(ArvBuffer* buffer, Nanos late_ns);
  bool on_send(GSocket* socket, const void* data, std::size_t size);  // false: do not send
  // Before on_send: a stream datagram of a frame with padded rows or chunks (camera.padded_rows,
  // camera.chunk_data, or ChunkModeActive set by the rig) is rewritten (gvsp_reshaper.hpp); `emit`
  // gets each datagram to send instead. false: send this one as it is.
  bool reshape(GSocket* socket, const void* data, std::size_t size, const GvspReshaper::Emit& emit);
  bool on_receive(ArvFakeCamera* cam);                                // false: ignore the datagram
  // A datagram on_send let through, to its socket: GVCP at once; GVSP at once too, unless
  // host.network_delay holds it (then a thread of its own sends it at its time, in order: nothing
  // lost, nothing overtaken). `real`: GLib's g_socket_send_to.
  using SendFn = gssize (*)(GSocket*, GSocketAddress*, const gchar*, gsize, GCancellable*, GError**);
  gssize transmit(SendFn real, GSocket* socket, GSocketAddress* address, const void* data, std::size_t size,
                  GCancellable* cancellable, GError** error);
  // After a stream datagram went (or was lost): a frame's truth line, due at its trailer, is written
  // now, or (its datagrams held) once the held trailer has left, with the leader's real send.
  void after_send(GSocket* socket);
  // After a stream datagram (sent or lost): after a frame's leader the fake pauses kLeaderGapNs, so
  // that the leader goes out alone and its receiver takes it before the data; with --link-mbps it
  // also waits while the link is busy with what was sent before. Sent back to back, three fakes on
  // one frame instant (SCHED_FIFO 1: ~190 packets each) held the rig's receiving threads (normal
  // priority) off their leaders by 0.6-2 ms every frame (issue 27). Pacing every packet at 1 Gb/s
  // fixed that too, but spread a LIDAR-triggered fake's sending over the stereo pair's trigger
  // instant (their trigger -> exposure p99 0.45 -> 0.8-1.2 ms): off by default.
  void pace(GSocket* socket, const void* data, std::size_t bytes);
  void finish();  // at exit: a camera still dead has its silence recorded

 private:
  // One stream datagram held by host.network_delay (or queued behind held ones), or a frame's truth
  // line to write once the datagrams before it have left.
  struct Held {
    Nanos due_mono = 0;
    std::vector<std::uint8_t> bytes;
    GSocket* socket = nullptr;          // referenced while held
    GSocketAddress* address = nullptr;  // referenced while held
    bool leader = false;
    bool record = false;                // a truth line, no datagram
    std::int64_t unit = -1;
    Nanos acq = 0, dev = 0, tx = 0, exposure = 0;
    truth::Fate fate = truth::Fate::kSent;
    std::uint64_t fault = 0;
    bool leader_held = false;           // its tx is the held leader's real send
  };
  void send_held();                   // the sender thread
  void release(Held& h, SendFn real);  // sends one (sender's lock held)
  [[nodiscard]] std::uint64_t silenced_by(double t) const;  // the event that keeps it silent, 0 = none
  [[nodiscard]] bool is_stream(GSocket* socket);  // the GVSP socket (found at its first datagram)
  GvspFrameShape shape_of(ArvFakeCamera* cam, double t, std::uint64_t dev_ns, std::uint32_t exposure_us) const;
  void update_ptp(ArvFakeCamera* cam, double t);

  CameraSchedule schedule_;
  std::unique_ptr<CameraTruth> truth_;
  double lost_ratio_ = 0;
  std::mt19937_64 rng_{0x5eed};

  // Main thread -> fake thread.
  std::atomic<std::uint64_t> dies_{0};          // the camera.dies event it is dead by, until it rebooted
  std::atomic<std::uint64_t> slow_{0};          // the camera.slow_open event it is slow by
  std::atomic<double> slow_after_s_{0};
  std::atomic<std::int64_t> slow_first_rx_{0};  // mono ns of the first attempt, 0 = none yet
  std::atomic<std::uint64_t> answered_{0};      // datagrams the fake handled since it booted
  std::set<std::uint64_t> slow_started_;        // main thread only

  // Fake thread only.
  struct Frame {
    std::int64_t unit = -1;
    Nanos acq = 0, dev = 0, tx = 0;
    std::uint32_t sent = 0, lost = 0, silenced = 0;
    std::uint64_t fault = 0;
    Nanos exposure_ns = 0;  // what its ChunkExposureTime says; 0: no chunks
  } frame_;
  FrameUnits units_;
  ExposureFaults exposure_;
  GSocket* gvsp_ = nullptr;
  GSocket* gvcp_ = nullptr;
  GvspFrameShape shape_;  // of the frame being sent
  GvspReshaper reshaper_;
  double link_mbps_ = 0;
  Nanos link_free_mono_ = 0;  // when the link has sent every datagram so far (CLOCK_MONOTONIC)
  bool frame_truth_due_ = false;    // the frame's trailer went: its truth line is due (after_send)
  bool frame_leader_held_ = false;  // its leader was held
  std::uint64_t frame_held_by_ = 0; // the delay that held any of its datagrams

  // host.network_delay (docs/faults.md): the plan's delays of this camera and what they hold.
  std::vector<faults::FaultEvent> delays_;
  faults::NetworkHold hold_;        // the fake thread's
  std::mutex held_mutex_;           // held_, stop_, sends of stream datagrams while any is held
  std::condition_variable held_cv_;
  std::deque<Held> held_;
  SendFn held_real_ = nullptr;
  bool held_stop_ = false;
  Nanos last_leader_tx_ = 0;        // the sender's: the last held leader's real send (vehicle time)
  bool held_send_failed_ = false;   // the sender's: a datagram of the frame being sent was refused
  std::thread sender_;
};

// The instance the interposed GLib functions call (null: pass everything through), and the fake
// camera whose PTP status a received request may read (null while it is rebooted).
void set_gige_fake_chaos(GigeFakeChaos* chaos);
void set_gige_fake_camera(ArvFakeCamera* cam);

}  // namespace sensor_rig::camera::mock
