#include "sensor_rig/drivers/dbw/dds_bridge.hpp"

#include <time.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <string>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/percentile.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/dbw/bridge/bridge_core.hpp"
#include "sensor_rig/drivers/dbw/dds_types.hpp"
#include "sensor_rig/drivers/dbw/dds_domain.hpp"

namespace sensor_rig::drivers {

using namespace sensor_rig::dbw;  // NOLINT(google-build-using-namespace): the node of the dbw area
namespace {

// Nearest-rank p50 and p99 of `v` (a sorted copy).
std::pair<double, double> p50_p99(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return {nearest_rank_percentile(v, 0.5), nearest_rank_percentile(v, 0.99)};
}

safety::Command to_command(const msg::DbwCommand& m) {
  safety::Command c;
  c.stamp = msg::from_time(m.header.stamp);
  c.seq = m.seq;
  c.enable = m.enable;
  c.steering_angle = m.steering_angle;
  c.steering_torque = m.steering_torque;
  c.throttle = m.throttle;
  c.brake = m.brake;
  c.accel = m.accel;
  c.gear = m.gear <= 4 ? static_cast<safety::Gear>(m.gear) : safety::Gear::none;
  if (m.gear > 4) c.throttle = std::nan("");  // an unknown gear makes the command invalid
  return c;
}

class Runner {
 public:
  Runner(const Protocol& p, can::Transport& bus, const DdsBridgeOptions& o)
      : p_(p), bus_(bus), o_(o), core_(p), participant_(domain_config()), cmd_topic_(participant_, kCmdTopic), status_topic_(participant_, kStatusTopic, status_qos()),
        state_topic_(participant_, kStateTopic), reader_(participant_, cmd_topic_),
        status_writer_(participant_, status_topic_, status_qos()), state_writer_(participant_, state_topic_) {
    latencies_.reserve(1 << 16);
    take_to_send_.reserve(1 << 16);
  }

  DdsBridgeStats run() {
    const Nanos start = monotonic_now_ns();
    end_ = o_.duration_s > 0 ? start + static_cast<Nanos>(o_.duration_s * 1e9) : -1;
    double dds_cpu_s = 0.0;
    std::thread dds_thread([this, &dds_cpu_s] {
      dds_loop();
      dds_cpu_s = thread_cpu_s();
    });
    can_loop();
    const double can_cpu_s = thread_cpu_s();
    stop_ = true;
    dds_thread.join();
    DdsBridgeStats s;
    s.commands = core_.safety().counters().commands;
    s.frames_sent = core_.counters().frames_sent;
    std::tie(s.latency_p50_us, s.latency_p99_us) = p50_p99(latencies_);
    s.latency_max_us = latencies_.empty() ? 0.0 : *std::max_element(latencies_.begin(), latencies_.end());
    std::tie(s.take_to_send_p50_us, s.take_to_send_p99_us) = p50_p99(take_to_send_);
    s.silence_to_neutral_ms = silence_to_neutral_ms_;
    s.status_published = status_published_;
    s.state_published = state_published_;
    s.transport_closed = transport_closed_;
    s.bridge_threads_cpu_s = dds_cpu_s + can_cpu_s;
    return s;
  }

 private:
  static double thread_cpu_s() {
    timespec ts{};
    ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
  }

  static dds::QosSpec status_qos() {
    dds::QosSpec q;
    q.depth = 16;  // bursts of events must not overwrite each other
    return q;
  }

  bool done() const { return stop_ || shutdown_requested() || (end_ > 0 && monotonic_now_ns() >= end_); }

  // Sends the current frames; caller holds mu_.
  void send_frames(Nanos now) {
    frames_.clear();
    core_.frames(now, frames_);
    for (const auto& f : frames_) {
      if (bus_.send(f) == can::IoStatus::ok) {
        ++core_.counters().frames_sent;
      } else {
        ++core_.counters().frames_refused;
      }
    }
    last_tx_ = monotonic_now_ns();
  }

  // Publishes pending safety events (and notes the silence->neutral time); caller holds mu_.
  void flush_events() {
    for (const auto& e : core_.safety().take_events()) {
      if (e.kind == safety::EventKind::transition && e.reason == safety::Reason::command_timeout && last_cmd_rx_ > 0) {
        silence_to_neutral_ms_ = static_cast<double>(vehicle_now_ns() - last_cmd_rx_) * 1e-6;
      }
      if (e.kind == safety::EventKind::transition || e.kind == safety::EventKind::engage_refused ||
          e.kind == safety::EventKind::fault) {
        log::info("dbw", std::string(safety::to_string(e.kind)) + ": " + std::string(safety::to_string(e.reason)) +
                             " -> " + std::string(safety::to_string(e.state)));
      }
      publish_status(e.t, &e);  // stamped with the event's time: frames after it reflect it
    }
  }

  // `e` == nullptr: the periodic sample.
  void publish_status(Nanos now, const safety::Event* e) {
    msg::DbwStatus m{};
    std::string frame_id = "base_link";
    const std::string reason(safety::to_string(core_.safety().reason()));
    const std::string event(e == nullptr ? std::string_view("periodic") : safety::to_string(e->kind));
    const std::string event_reason(e == nullptr ? std::string_view("none") : safety::to_string(e->reason));
    std::string detail;
    if (e != nullptr && e->kind == safety::EventKind::limit) {
      char buf[160];
      std::snprintf(buf, sizeof buf, "%s %s: requested %g applied %g%s", std::string(safety::to_string(e->violation.axis)).c_str(),
                    e->violation.rate ? "rate" : "range", e->violation.requested, e->violation.applied,
                    e->violation.rejected ? " (rejected)" : " (clamped)");
      detail = buf;
    }
    const std::string hash = p_.config_hash();
    const std::string proto = p_.mapping_path();
    const std::string bus_state = can::to_string(bus_.bus_state());
    m.header.stamp = msg::to_time(now);
    m.header.frame_id = frame_id.data();
    m.state = core_.safety().state() == safety::State::engaged ? 1 : 0;
    m.reason = const_cast<char*>(reason.c_str());
    m.event = const_cast<char*>(event.c_str());
    m.event_reason = const_cast<char*>(event_reason.c_str());
    m.detail = detail.data();
    m.config_hash = const_cast<char*>(hash.c_str());
    m.protocol = const_cast<char*>(proto.c_str());
    const auto& ecu = core_.ecu();
    m.ecu_ready = ecu.ready;
    m.ecu_engaged = ecu.engaged;
    m.driver_override = ecu.override;
    m.ecu_fault = ecu.fault;
    m.bus_state = const_cast<char*>(bus_state.c_str());
    const auto& c = core_.safety().counters();
    m.commands = c.commands;
    m.commands_ignored = c.ignored_stale + c.ignored_sequence + c.ignored_stamp;
    m.commands_rejected = c.rejected;
    m.commands_clamped = c.clamped;
    m.e2e_errors = c.e2e_errors;
    m.frames_sent = core_.counters().frames_sent;
    m.frames_received = core_.counters().frames_received;
    if (status_writer_.write(m, now) >= 0) ++status_published_;
  }

  void publish_state(const VehicleFeedback& fb) {
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
    if (state_writer_.write(m, vehicle_now_ns()) >= 0) ++state_published_;
  }

  void dds_loop() {
    while (!done()) {
      if (!reader_.wait(20)) continue;
      reader_.take([this](const msg::DbwCommand& m, const dds_sample_info_t& info) {
        std::lock_guard<std::mutex> lock(mu_);
        // Read under the lock: no frame of the CAN thread can go out between this time (the time of
        // any event the command causes) and the frames it produces.
        const Nanos taken = vehicle_now_ns();
        core_.on_command(to_command(m), taken);
        last_cmd_rx_ = taken;
        send_frames(taken);
        const Nanos sent = vehicle_now_ns();
        latencies_.push_back(static_cast<double>(sent - info.source_timestamp) * 1e-3);
        take_to_send_.push_back(static_cast<double>(sent - taken) * 1e-3);
        flush_events();
      });
    }
  }

  void can_loop() {
    const Nanos period = p_.timing().tx_period_ns;
    Nanos next_status = monotonic_now_ns();
    can::BusState bus_state = bus_.bus_state();
    can::RxFrame rx;
    while (!done()) {
      const auto st = bus_.receive(rx, 1);
      std::lock_guard<std::mutex> lock(mu_);
      const Nanos now = vehicle_now_ns();
      if (st == can::IoStatus::ok) {
        if (core_.on_frame(rx, now) == RxKind::feedback) publish_state(core_.feedback());
      } else if (st == can::IoStatus::closed) {
        log::error("dbw", "CAN transport closed: " + bus_.name());
        core_.safety().on_bus_state(true, now);  // nothing reaches the ECU any more
        flush_events();
        transport_closed_ = true;
        break;
      }
      if (bus_.bus_state() != bus_state) {
        bus_state = bus_.bus_state();
        core_.on_bus_state(bus_state, now);
      }
      const bool was_engaged = core_.safety().state() == safety::State::engaged;
      core_.safety().tick(now);  // timeouts at 1 ms resolution
      const bool dropped = was_engaged && core_.safety().state() != safety::State::engaged;
      const Nanos mono = monotonic_now_ns();
      if (dropped || mono - last_tx_ >= period) send_frames(now);  // disengage goes out at once
      flush_events();
      if (mono >= next_status) {
        next_status = mono + 100'000'000;
        publish_status(now, nullptr);
      }
    }
  }

  const Protocol& p_;
  can::Transport& bus_;
  DdsBridgeOptions o_;
  BridgeCore core_;
  dds::Participant participant_;
  dds::Topic<msg::DbwCommand> cmd_topic_;
  dds::Topic<msg::DbwStatus> status_topic_;
  dds::Topic<msg::VehicleState> state_topic_;
  dds::Reader<msg::DbwCommand> reader_;
  dds::Writer<msg::DbwStatus> status_writer_;
  dds::Writer<msg::VehicleState> state_writer_;
  std::mutex mu_;
  std::atomic<bool> stop_{false};
  Nanos end_ = -1;
  Nanos last_tx_ = 0;
  Nanos last_cmd_rx_ = 0;
  double silence_to_neutral_ms_ = -1.0;
  std::vector<can::Frame> frames_;
  std::vector<double> latencies_;
  std::vector<double> take_to_send_;
  std::uint64_t status_published_ = 0;
  std::uint64_t state_published_ = 0;
  bool transport_closed_ = false;
};

}  // namespace

DdsBridgeStats run_dds_bridge(const Protocol& protocol, can::Transport& bus, const DdsBridgeOptions& o) {
  Runner r(protocol, bus, o);
  return r.run();
}

}  // namespace sensor_rig::drivers
