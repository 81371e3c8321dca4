#include "sensor_rig/drivers/dbw/dds_bridge.hpp"

#include <time.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

#include "bridge_outbox.hpp"
#include "latency_histogram.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/dbw/bridge/bridge_core.hpp"
#include "sensor_rig/dds/diagnostics.hpp"
#include "sensor_rig/dds/on_demand_writer.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"
#include "sensor_rig/drivers/dbw/dds_domain.hpp"
#include "sensor_rig/drivers/dbw/dds_types.hpp"

namespace sensor_rig::drivers {

using namespace sensor_rig::dbw;  // NOLINT(google-build-using-namespace): the node of the dbw area
namespace {

safety::Command to_command(const msg::DbwCommand& m, safety::WriterId writer) {
  safety::Command c;
  c.stamp = msg::from_time(m.header.stamp);
  c.seq = m.seq;
  c.writer = writer;
  c.enable = m.enable;
  c.steering_angle = m.steering_angle;
  c.steering_torque = m.steering_torque;
  c.throttle = m.throttle;
  c.brake = m.brake;
  c.accel = m.accel;
  c.gear = m.gear <= 4 ? static_cast<safety::Gear>(m.gear) : safety::Gear::kNone;
  if (m.gear > 4) c.throttle = std::nan("");  // an unknown gear makes the command invalid
  return c;
}

// A DDS write succeeded (the wrapper's return type is an int code or a result object).
template <class R>
bool written(const R& r) {
  if constexpr (std::is_integral_v<R>) {
    return r >= 0;
  } else {
    return r.ok();
  }
}

double thread_cpu_s() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

dds::QosSpec status_qos() {
  dds::QosSpec q;
  q.depth = 16;  // bursts of events must not overwrite each other
  return q;
}

// The raw channel of the bus: every received frame while recorded (rig record --raw). Reliable
// keep-last 256: a recorder that lags a little loses nothing, and the write never blocks.
constexpr const char* kRawFramesTopic = "/vehicle/can/frames";
dds::QosSpec raw_frames_qos() {
  dds::QosSpec q;
  q.depth = 256;
  return q;
}

class Runner {
 public:
  Runner(const Protocol& p, can::Transport& bus, const DdsBridgeOptions& o)
      : p_(p), bus_(bus), o_(o), core_(p), security_(security_config(o.security_dir, o.identity)),
        participant_(domain_config(o.domain), security_),
        cmd_topic_(participant_, kCmdTopic),
        status_topic_(participant_, kStatusTopic, status_qos()), state_topic_(participant_, kStateTopic),
        reader_(participant_, cmd_topic_), status_writer_(participant_, status_topic_, status_qos()),
        state_writer_(participant_, state_topic_), stamps_(participant_), diagnostics_(participant_),
        raw_frames_(participant_, kRawFramesTopic, raw_frames_qos()), bus_name_(bus.name()) {
    if (security_.enabled()) expiry_ = dds::security_expiry(security_);
    if (raw_frames_.refused())
      log::warn("dbw", std::string("the security grants do not name ") + kRawFramesTopic +
                           ": the raw CAN channel stays off (rig security init makes grants that do)");
    frames_.reserve(16);
  }

  DdsBridgeStats run() {
    const Nanos start = monotonic_now_ns();
    end_ = o_.duration_s > 0 ? start + static_cast<Nanos>(o_.duration_s * 1e9) : -1;
    double dds_cpu_s = 0.0;
    std::thread publisher([this] { publish_loop(); });
    std::thread dds_thread([this, &dds_cpu_s] {
      dds_loop();
      dds_cpu_s = thread_cpu_s();
    });
    can_loop();
    stop_sequence();
    const double can_cpu_s = thread_cpu_s();
    stop_ = true;
    dds_thread.join();
    // Stamps still waiting for an ECU status go out without it (the threads that complete them are done).
    awaiting_ecu_.expire(0, -1, [this](const OutboxItem& it) { outbox_.push(it, false); });
    publishing_ = false;
    publisher.join();
    DdsBridgeStats s;
    s.commands = core_.safety().counters().commands;
    s.frames_sent = core_.counters().frames_sent;
    s.latency_p50_us = latency_.percentile_us(0.5);
    s.latency_p99_us = latency_.percentile_us(0.99);
    s.latency_max_us = latency_.max_us();
    s.take_to_send_p50_us = take_to_send_.percentile_us(0.5);
    s.take_to_send_p99_us = take_to_send_.percentile_us(0.99);
    s.silence_to_neutral_ms = silence_to_neutral_ms_;
    s.status_published = status_published_;
    s.state_published = state_published_;
    s.transport_closed = transport_closed_;
    s.bridge_threads_cpu_s = dds_cpu_s + can_cpu_s;
    s.commands_deferred = core_.counters().commands_deferred;
    s.neutral_sets_on_stop = neutral_sets_on_stop_;
    s.outbox_dropped = outbox_.dropped();
    return s;
  }

 private:
  bool done() const { return stop_ || shutdown_requested() || (end_ > 0 && monotonic_now_ns() >= end_); }

  // Puts the current frame set on the bus; caller holds mu_.
  void send_frames(Nanos mono) {
    frames_.clear();
    core_.frames(mono, frames_);
    for (const auto& f : frames_) {
      if (bus_.send(f) == can::IoStatus::kOk) {
        ++core_.counters().frames_sent;
      } else {
        ++core_.counters().frames_refused;
      }
    }
  }

  StatusSnapshot snapshot() {  // caller holds mu_
    StatusSnapshot s;
    s.state = core_.safety().state();
    s.reason = core_.safety().reason();
    s.counters = core_.safety().counters();
    s.ecu = core_.ecu();
    s.bus_state = can::to_string(bus_.bus_state());
    s.frames_sent = core_.counters().frames_sent;
    s.frames_received = core_.counters().frames_received;
    return s;
  }

  // Hands the safety events of this step to the publisher, in vehicle time (`mono` and `vnow` were
  // read together under mu_: every frame after that stamp reflects the event). Caller holds mu_.
  void hand_over_events(Nanos mono, Nanos vnow) {
    const auto events = core_.safety().events();
    if (events.empty()) return;
    OutboxItem item;
    item.status = snapshot();
    for (const auto& e : events) {
      if (e.kind == safety::EventKind::kTransition && e.reason == safety::Reason::kCommandTimeout && last_cmd_rx_ > 0) {
        silence_to_neutral_ms_ = static_cast<double>(monotonic_now_ns() - last_cmd_rx_) * 1e-6;
      }
      item.event = e;
      item.event.t = e.t - mono + vnow;
      outbox_.push(item, true);
    }
    core_.safety().clear_events();
  }

  void dds_loop() {
    while (!done()) {
      if (!reader_.wait(20)) continue;
      reader_.take([this](const msg::DbwCommand& m, const dds_sample_info_t& info) {
        const safety::Command c = to_command(m, info.publication_handle);
        Nanos taken = 0, ready = 0, sent = 0;
        {
          std::lock_guard<std::mutex> lock(mu_);
          // Read under the lock: no frame of the CAN thread goes out between this time (the time of
          // any event the command causes) and the frames it produces.
          const auto now = clock_pair_now();
          const Nanos mono = now.monotonic_ns;
          taken = now.vehicle_ns;
          const bool changed = core_.on_command(c, mono, taken);
          last_cmd_rx_ = mono;
          if (core_.transmit_due(mono, changed)) {
            ready = vehicle_now_ns();
            send_frames(mono);
            sent = vehicle_now_ns();
            // The stamps wait (under mu_, as the CAN thread completes them) for the ECU status after.
            OutboxItem item;
            item.kind = OutboxItem::Kind::kStamps;
            item.stamp = c.stamp;
            item.seq = m.seq;
            item.stamps = dds::SampleStamps{c.stamp, taken, taken, ready, ready, sent, 1, 0, static_cast<std::uint32_t>(sizeof m)};
            awaiting_ecu_.on_written(item, [this](const OutboxItem& it) { outbox_.push(it, false); });
          }
          hand_over_events(mono, taken);
        }
        if (sent == 0) return;
        latency_.record(static_cast<double>(sent - info.source_timestamp) * 1e-3);
        take_to_send_.record(static_cast<double>(sent - taken) * 1e-3);
      });
    }
  }

  void can_loop() {
    can::BusState bus_state = bus_.bus_state();
    can::RxFrame rx;
    while (!done()) {
      const auto st = bus_.receive(rx, 1);
      std::lock_guard<std::mutex> lock(mu_);
      const auto now = clock_pair_now();
      const Nanos mono = now.monotonic_ns;
      const Nanos vnow = now.vehicle_ns;
      const auto push = [this](const OutboxItem& it) { outbox_.push(it, false); };
      if (st == can::IoStatus::kOk) {
        if (raw_frames_.active()) raw_ring_.push(rx);  // one relaxed load when nobody records
        const RxKind kind = awaiting_ecu_.on_frame(core_, rx, mono, push);  // core_.on_frame + the ecu stage
        if (kind == RxKind::kFeedback) {
          OutboxItem item;
          item.kind = OutboxItem::Kind::kState;
          item.feedback = core_.feedback();
          item.stamps.ready_ns = vnow;  // decoded and checked: the sample is ready to publish
          if (!outbox_.push(item, false)) core_.feedback_not_delivered();
        }
      } else if (st == can::IoStatus::kClosed) {
        log::error("dbw", "CAN transport closed: " + bus_.name());
        core_.safety().on_bus_state(true, mono);  // nothing reaches the ECU any more
        hand_over_events(mono, vnow);
        transport_closed_ = true;
        break;
      }
      if (bus_.bus_state() != bus_state) {
        bus_state = bus_.bus_state();
        core_.on_bus_state(bus_state, mono);
      }
      // Timeouts at 1 ms resolution; a disengage (also one an ECU frame caused) goes out now.
      if (core_.transmit_due(mono, false)) send_frames(mono);
      hand_over_events(mono, vnow);
      awaiting_ecu_.expire(vnow, p_.timing().ecu_timeout_ns, push);
    }
  }

  // Stopping is a disengage: neutral frames for a few periods, then the end.
  void stop_sequence() {
    if (transport_closed_) return;
    const Nanos period = p_.timing().tx_period_ns;
    for (int i = 0; i < o_.neutral_periods_on_stop; ++i) {
      {
        std::lock_guard<std::mutex> lock(mu_);
        const Nanos mono = monotonic_now_ns();
        core_.safety().shutdown(mono);
        send_frames(mono);
        ++neutral_sets_on_stop_;
        hand_over_events(mono, vehicle_now_ns());
      }
      if (i + 1 < o_.neutral_periods_on_stop) {
        timespec ts{0, static_cast<long>(period)};
        ::nanosleep(&ts, nullptr);
      }
    }
  }

  // ---- the publisher thread: every DDS write except the command path's reads -----------------

  void publish_loop() {
    Nanos next_status = monotonic_now_ns();
    Nanos next_diag = next_status + 1'000'000'000;
    while (true) {
      const bool last_round = !publishing_;
      while (outbox_.drain(last_round ? 0 : 5, [this](const OutboxItem& it) { publish(it); }) > 0) {
      }
      raw_ring_.drain([this](const can::RxFrame& f) { publish_raw(f); });
      if (last_round) break;
      const Nanos mono = monotonic_now_ns();
      if (mono >= next_status) {
        next_status = mono + 100'000'000;
        OutboxItem item;
        item.kind = OutboxItem::Kind::kPeriodic;
        std::lock_guard<std::mutex> lock(mu_);  // behind every event already handed over
        item.status = snapshot();
        item.event.t = vehicle_now_ns();
        outbox_.push(item, true);
      }
      if (mono >= next_diag) {
        next_diag = mono + 1'000'000'000;
        publish_diagnostics();
      }
    }
  }

  void publish(const OutboxItem& it) {
    switch (it.kind) {
      case OutboxItem::Kind::kEvent: {
        const auto& e = it.event;
        if (e.kind == safety::EventKind::kTransition || e.kind == safety::EventKind::kEngageRefused ||
            e.kind == safety::EventKind::kFault) {
          log::info("dbw", std::string(safety::to_string(e.kind)) + ": " + std::string(safety::to_string(e.reason)) +
                               " -> " + std::string(safety::to_string(e.state)));
        }
        publish_status(e.t, &e, it.status);
        break;
      }
      case OutboxItem::Kind::kPeriodic: publish_status(it.event.t, nullptr, it.status); break;
      case OutboxItem::Kind::kStamps: {
        char frame_id[] = "base_link";
        stamps_.write(kCmdTopic, msg::to_time(it.stamp), frame_id, it.seq, it.stamps);
        break;
      }
      case OutboxItem::Kind::kState: publish_state(it.feedback, it.stamps.ready_ns); break;
    }
  }

  // One received frame on the raw channel, as can_msgs/Frame has it plus CAN FD's flags.
  void publish_raw(const can::RxFrame& rx) {
    msg::CanFrame m{};
    m.header.stamp = msg::to_time(rx.stamp);
    m.header.frame_id = bus_name_.data();
    m.id = rx.frame.id;
    m.is_rtr = rx.frame.rtr;
    m.is_extended = rx.frame.extended;
    m.is_error = rx.frame.error;
    m.is_fd = rx.frame.fd;
    m.brs = rx.frame.brs;
    m.esi = rx.frame.esi;
    m.data._buffer = const_cast<std::uint8_t*>(rx.frame.data.data());  // never written through
    m.data._length = m.data._maximum = rx.frame.len;
    if (raw_frames_.write(m, vehicle_now_ns()).ok()) {
      ++raw_frames_written_;
    } else {
      ++raw_frames_failed_;
    }
  }

  // `e` == nullptr: the periodic sample.
  void publish_status(Nanos stamp, const safety::Event* e, const StatusSnapshot& snap) {
    msg::DbwStatus m{};
    char frame_id[] = "base_link";
    const std::string reason(safety::to_string(snap.reason));
    const std::string event(e == nullptr ? std::string_view("periodic") : safety::to_string(e->kind));
    const std::string event_reason(e == nullptr ? std::string_view("none") : safety::to_string(e->reason));
    char detail[160] = "";
    if (e != nullptr && e->kind == safety::EventKind::kLimit) {
      const auto& v = e->violation;
      const char* what = v.rate ? "rate" : v.lateral ? "lateral" : v.interlock ? "brake-interlock" : "range";
      std::snprintf(detail, sizeof detail, "%s %s: requested %g applied %g%s", std::string(safety::to_string(v.axis)).c_str(),
                    what, v.requested, v.applied, v.rejected ? " (rejected)" : " (clamped)");
    }
    const std::string hash = p_.config_hash();
    const std::string proto = p_.mapping_path();
    std::string bus_state = snap.bus_state;
    m.header.stamp = msg::to_time(stamp);
    m.header.frame_id = frame_id;
    // An event's sample shows the state right after that event (a limit reported while engaging
    // precedes the engagement); the rest is the status once the whole step was handled.
    const safety::State state = e != nullptr ? e->state : snap.state;
    m.state = state == safety::State::kEngaged ? 1 : 0;
    m.reason = const_cast<char*>(reason.c_str());
    m.event = const_cast<char*>(event.c_str());
    m.event_reason = const_cast<char*>(event_reason.c_str());
    m.detail = detail;
    m.config_hash = const_cast<char*>(hash.c_str());
    m.protocol = const_cast<char*>(proto.c_str());
    m.ecu_ready = snap.ecu.ready;
    m.ecu_engaged = snap.ecu.engaged;
    m.driver_override = snap.ecu.override;
    m.ecu_fault = snap.ecu.fault;
    m.bus_state = bus_state.data();
    const auto& c = snap.counters;
    m.commands = c.commands;
    m.commands_ignored = c.ignored_stale + c.ignored_sequence + c.ignored_stamp + c.ignored_writer;
    m.commands_rejected = c.rejected;
    m.commands_clamped = c.clamped;
    m.e2e_errors = c.e2e_errors;
    m.frames_sent = snap.frames_sent;
    m.frames_received = snap.frames_received;
    if (written(status_writer_.write(m, stamp))) ++status_published_;
  }

  // One sample per feedback frame, with its source stamps on /rig/stamps like every sensor topic: the
  // monitor shows its latency by stage, and `rig chaos` holds it against the mock ECU's truth.
  void publish_state(const VehicleFeedback& fb, Nanos ready_ns) {
    msg::VehicleState m{};
    char frame_id[] = "base_link";
    m.header.stamp = msg::to_time(fb.stamp);
    m.header.frame_id = frame_id;
    m.speed = fb.speed;
    m.wheel_speed_fl = fb.wheels[0];
    m.wheel_speed_fr = fb.wheels[1];
    m.wheel_speed_rl = fb.wheels[2];
    m.wheel_speed_rr = fb.wheels[3];
    m.steering_angle = fb.steering_angle;
    m.yaw_rate = fb.yaw_rate;
    m.gear = static_cast<std::uint8_t>(fb.gear);
    dds::SampleStamps st;
    st.acquisition_ns = fb.stamp;  // the frame's kernel receive time (SPEC §6: CAN)
    st.first_rx_ns = st.last_rx_ns = fb.stamp;
    st.ready_ns = ready_ns;
    st.publish_ns = vehicle_now_ns();
    st.packets = 1;
    st.size_bytes = static_cast<std::uint32_t>(sizeof m);
    const std::uint64_t seq = state_seq_++;
    if (written(state_writer_.write(m, st.publish_ns))) {
      ++state_published_;
      st.written_ns = vehicle_now_ns();
      stamps_.write(kStateTopic, m.header.stamp, frame_id, seq, st);
    } else {
      state_write_failures_.fetch_add(1, std::memory_order_relaxed);
    }
  }

  void publish_diagnostics() {
    StatusSnapshot snap;
    std::uint64_t deferred = 0, feedback_lost = 0, feedback_gaps_unknown = 0;
    {
      std::lock_guard<std::mutex> lock(mu_);
      snap = snapshot();
      deferred = core_.counters().commands_deferred;
      feedback_lost = core_.feedback_lost();
      feedback_gaps_unknown = core_.feedback_gaps_unknown();
    }
    dds::DriverStatus d;
    d.name = "dbw/bridge";
    d.hardware_id = bus_.name();
    const bool faulted = snap.ecu.fault || snap.bus_state == std::string_view("bus_off");
    d.level = faulted ? dds::Level::kWarn : dds::Level::kOk;
    d.message = std::string(safety::to_string(snap.state)) + " (" + std::string(safety::to_string(snap.reason)) + ")";
    d.add("protocol", p_.mapping_path());
    d.add("config_hash", p_.config_hash());
    d.add("bus_state", snap.bus_state);
    d.add_number("commands", snap.counters.commands);
    d.add_number("commands_ignored", snap.counters.ignored_stale + snap.counters.ignored_sequence +
                                         snap.counters.ignored_stamp + snap.counters.ignored_writer);
    d.add_number("commands_rejected", snap.counters.rejected);
    d.add_number("commands_clamped", snap.counters.clamped);
    d.add_number("commands_deferred", deferred);
    d.add_number("e2e_errors", snap.counters.e2e_errors);
    d.add_number("frames_sent", snap.frames_sent);
    d.add_number("frames_received", snap.frames_received);
    d.add_number("outbox_dropped", outbox_.dropped());
    if (raw_frames_written_ + raw_frames_failed_ + raw_ring_.dropped() > 0) {
      d.add("raw_topic", kRawFramesTopic);
      d.add_number("raw_frames", raw_frames_written_);
      d.add_number("raw_frames_dropped", raw_ring_.dropped() + raw_frames_failed_);
    }
    // Issue 28: a lapsed certificate, grant or CA stops the bridge taking commands; warn 30 days ahead.
    if (security_.enabled()) dds::report_expiry(d, security_.identity, expiry_, std::time(nullptr));
    // /vehicle/state's own losses, on its topic, as every sensor node reports its units: the feedback
    // frames the ECU sent that never became a sample (FrameLossCounter says how they are counted).
    dds::DriverStatus state;
    state.name = "dbw/vehicle_state";
    state.hardware_id = bus_.name();
    state.level = dds::Level::kOk;
    state.message = "feedback frames lost or refused: counted";
    state.add("topic", kStateTopic);
    state.add_number("counted_lost", feedback_lost + state_write_failures_.load(std::memory_order_relaxed));
    state.add_number("gaps_unknown", feedback_gaps_unknown);
    state.add_number("published", state_published_);
    diagnostics_.publish({d, state});
  }

  const Protocol& p_;
  can::Transport& bus_;
  DdsBridgeOptions o_;
  BridgeCore core_;
  dds::SecurityConfig security_;
  dds::SecurityExpiry expiry_;
  dds::Participant participant_;
  dds::Topic<msg::DbwCommand> cmd_topic_;
  dds::Topic<msg::DbwStatus> status_topic_;
  dds::Topic<msg::VehicleState> state_topic_;
  dds::Reader<msg::DbwCommand> reader_;
  dds::Writer<msg::DbwStatus> status_writer_;
  dds::Writer<msg::VehicleState> state_writer_;
  dds::StampsWriter stamps_;
  dds::DiagnosticsPublisher diagnostics_;
  dds::OnDemandWriter<msg::CanFrame> raw_frames_;
  std::string bus_name_;  // the raw frames' frame_id
  RawFrameRing raw_ring_;
  std::uint64_t raw_frames_written_ = 0, raw_frames_failed_ = 0;  // publisher thread only
  std::mutex mu_;  // the core, the transport's send side, last_cmd_rx_, silence_to_neutral_ms_
  std::atomic<bool> stop_{false};
  std::atomic<bool> publishing_{true};
  Nanos end_ = -1;
  Nanos last_cmd_rx_ = 0;  // monotonic
  double silence_to_neutral_ms_ = -1.0;
  std::vector<can::Frame> frames_;
  Outbox outbox_;
  AwaitingEcu awaiting_ecu_;  // under mu_
  LatencyHistogram latency_;       // DDS thread only (read after it ended)
  LatencyHistogram take_to_send_;  // DDS thread only
  std::uint64_t status_published_ = 0;  // publisher thread only
  std::uint64_t state_published_ = 0;   // publisher thread only
  std::atomic<std::uint64_t> state_write_failures_{0};
  std::uint64_t state_seq_ = 0;  // publisher thread only
  std::uint64_t neutral_sets_on_stop_ = 0;
  bool transport_closed_ = false;  // CAN thread only
};

}  // namespace

DdsBridgeStats run_dds_bridge(const Protocol& protocol, can::Transport& bus, const DdsBridgeOptions& o) {
  auto r = std::make_unique<Runner>(protocol, bus, o);  // the histograms are large: not on the stack
  return r->run();
}

}  // namespace sensor_rig::drivers
