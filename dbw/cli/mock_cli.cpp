// `rig mock paravan [--transport SPEC] [--config YAML] [--log FILE] [--fault SPEC]... [--duration S]`
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <thread>

#include "sensor_rig/common/fault_plan.hpp"
#include "sensor_rig/common/network_hold.hpp"
#include "sensor_rig/common/cli.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/common/truth_record.hpp"
#include "sensor_rig/dbw/bridge/defaults.hpp"
#include "dbw_commands.hpp"
#include "sensor_rig/dbw/mock/mock_runner.hpp"

namespace sensor_rig::dbw {
namespace {

struct MockOptions {
  std::string transport = std::string("unix-listen:") + kDefaultBusSocket;
  std::string config;
  std::string log;
  std::vector<std::string> faults;
  double duration = 0.0;
  std::uint64_t seed = 1;
  bool print_state = false;
  std::string device = "paravan";  // its name in a fault plan (rig chaos)
};

// The vocabulary's dbw.* kinds as the mock ECU's own faults.
mock::Fault from_event(const faults::FaultEvent& e, double start_s) {
  static const std::map<std::string, mock::FaultKind> kKinds{
      {"dbw.loss", mock::FaultKind::kFrameLoss},         {"dbw.bad_crc", mock::FaultKind::kBadCrc},
      {"dbw.stuck_counter", mock::FaultKind::kStuckCounter}, {"dbw.override", mock::FaultKind::kDriverOverride},
      {"dbw.ecu_fault", mock::FaultKind::kEcuFault},     {"dbw.bus_off", mock::FaultKind::kBusOff},
      {"dbw.no_status", mock::FaultKind::kNoStatus}};
  mock::Fault f;
  f.kind = kKinds.at(e.kind);
  f.value = e.kind == "dbw.loss" ? e.number("p", 0.1) : 1.0;
  f.start_s = start_s;
  f.duration_s = e.duration_s;
  f.id = e.id;
  return f;
}

// Under `rig chaos`: the plan's dbw.* faults of this device, timed from this process's start (the
// ECU's clock), each recorded in the truth record when it begins. A restarted mock takes what has not
// ended yet: the faults over before its start were its predecessor's.
class PlannedFaults {
 public:
  PlannedFaults(const std::string& device, std::vector<mock::Fault>& faults) {
    const std::string plan_path = faults::chaos_plan_path();
    if (plan_path.empty()) return;
    const faults::Plan plan = faults::read_plan(plan_path);
    const double offset_s = static_cast<double>(plan.epoch_mono_ns - monotonic_now_ns()) * 1e-9;
    for (const auto& e : plan.for_device(device)) {
      // Over before this process started: its predecessor's. Still on (the mock was restarted inside
      // it): injected for what is left of it, and recorded again by this run.
      const bool delay = e.kind == "host.network_delay" && e.device != "lo";
      if ((e.kind.rfind("dbw.", 0) != 0 && !delay) || offset_s + e.at_s + e.duration_s < 0) continue;
      faults::FaultEvent left = e;
      if (offset_s + e.at_s < 0) {
        left.duration_s = offset_s + e.at_s + e.duration_s;
        left.at_s = -offset_s;
      }
      if (!delay) faults.push_back(from_event(left, offset_s + left.at_s));
      events_.push_back(left);
    }
    // host.network_delay: the ECU's frames held on their way to the bus (the bus between ECU and PU
    // delivers them late, in order), recorded per feedback frame with the fault's id.
    hold_ = faults::NetworkHold(faults::NetworkHold::windows_of(plan, device));
    // Its units: the feedback frames, each one sample of /vehicle/state (the bridge publishes one per
    // frame it takes, stamped with the frame's receive time).
    truth_ = std::make_unique<truth::Writer>(
        faults::chaos_truth_path(device), truth::Header{device, "dbw", "mock Paravan ECU", "/vehicle/state", "can_frame", "CLOCK_MONOTONIC"});
    epoch_mono_ = plan.epoch_mono_ns;
    thread_ = std::thread([this] { record(); });
  }
  ~PlannedFaults() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }

  // Records each feedback frame `ecu` makes from now on: a unit of one part, with its fate. The ECU
  // says what it did to the frame (dropped, damaged); the runner says whether the bus carried it to
  // anyone (a frame made before the bridge reconnected to a restarted ECU reached no one: not sent).
  void observe(mock::MockEcu& ecu, const Protocol& protocol, mock::RunOptions& run) {
    if (!truth_) return;
    const RoleMessage* feedback = protocol.rx("feedback");
    if (feedback == nullptr) return;
    ecu.set_observer([this](const mock::EmittedFrame& e) {
      if (e.role != "feedback") return;
      // The step's instant (e.now, monotonic) in vehicle time: the hold counts from it, and a clock
      // read here came after the step's sends, later by a preempted thread (a held frame's tx - made
      // read 49.3 ms under a 50 ms hold in a fresh-clone suite run).
      const Nanos made = e.now + clock_pair_now().vehicle_minus_monotonic();
      if (e.fate == mock::EmittedFrame::Fate::kDropped) {
        record_unit(e, false, made, made, made, 0);
      } else {
        pending_.push_back(Pending{e, made});
      }
    });
    if (!hold_.empty())
      run.depart = [this](const can::Frame&, Nanos made_mono) {
        const auto d = hold_.due(made_mono);
        held_by_.push_back(d.fault);  // one per frame, in the order they leave
        return d.at_mono;
      };
    run.on_sent = [this, feedback](const can::Frame& f, bool heard, Nanos handed_ns, Nanos returned_ns) {
      std::uint64_t held_by = 0;
      if (!held_by_.empty()) {
        held_by = held_by_.front();
        held_by_.pop_front();
      }
      if (pending_.empty() || !feedback->matches(f)) return;
      record_unit(pending_.front().frame, heard, handed_ns, returned_ns, pending_.front().made, held_by);
      pending_.pop_front();
    };
  }

 private:
  // `veh`: when the frame was handed to the bus (taken just before the send), or made, for a dropped
  // one; `returned`: when the send returned. A CAN sample's acquisition is its kernel receive time
  // (SPEC 6), the send's instant, which lies in [veh, returned] whatever happens to this process
  // around it: the unit's `acq` is `veh`, the part's `tx` is `returned` (the judge matches a sample to
  // the send that brackets its stamp). The part's `acq` is when the ECU made the frame (vehicle time;
  // `dev` the ECU's monotonic clock), earlier by a host.network_delay's hold (`held_by`, its id on the
  // part, fate sent).
  void record_unit(const mock::EmittedFrame& e, bool on_bus, Nanos veh, Nanos returned, Nanos made, std::uint64_t held_by) {
    using F = mock::EmittedFrame::Fate;
    const auto id = static_cast<std::int64_t>(units_++);
    truth_->unit({id, veh, e.now, 1});
    truth::PartRecord p;
    p.seq = static_cast<std::uint64_t>(id);
    p.unit = id;
    p.acq_ns = made;
    p.dev_ns = e.now;
    p.fault = e.fault != 0 ? e.fault : held_by;
    if (e.fate == F::kDropped) {
      p.fate = truth::Fate::kDropped;
    } else if (!on_bus) {
      p.fate = truth::Fate::kNotSent;  // no node on the bus: made, heard by none, not a loss
    } else {
      p.tx_ns = returned;
      p.fate = e.fate == F::kSent ? truth::Fate::kSent : truth::Fate::kCorrupted;
    }
    truth_->part(p);
    // On disk before the bridge can publish it: a killed ECU (host.kill_mock) leaves no sample the
    // truth lacks. 100 writes a second, a few microseconds each.
    truth_->flush();
  }

  void record() {
    for (const auto& e : events_) {
      const Nanos at = epoch_mono_ + static_cast<Nanos>(e.at_s * 1e9);
      while (!stop_ && monotonic_now_ns() < at) ::usleep(5'000);
      if (stop_) return;
      const Nanos veh = vehicle_now_ns();
      std::string detail = faults::to_string(faults::FaultSpec{e.kind, e.params, e.at_s, e.duration_s, 0, e.device});
      if (e.kind == "host.network_delay") detail += ", via=mock ECU (its frames held on the bus, order kept)";
      truth_->fault({e.id, e.kind, veh, veh + static_cast<Nanos>(e.duration_s * 1e9), -1, detail});
      truth_->flush();
    }
  }
  std::vector<faults::FaultEvent> events_;
  std::unique_ptr<truth::Writer> truth_;
  std::uint64_t units_ = 0;                    // the ECU's thread only
  struct Pending {
    mock::EmittedFrame frame;
    Nanos made = 0;  // vehicle time it was made
  };
  std::deque<Pending> pending_;                // made, not yet handed to the bus (the ECU's thread)
  faults::NetworkHold hold_;                   // host.network_delay's windows (the ECU's thread)
  std::deque<std::uint64_t> held_by_;          // per frame handed to the hold: the delay holding it
  Nanos epoch_mono_ = 0;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

int run_mock_paravan(const MockOptions& o) {
  const Protocol protocol = Protocol::load(o.config.empty() ? default_protocol_config() : o.config);
  std::vector<mock::Fault> faults;
  for (const auto& f : o.faults) {
    try {
      faults.push_back(mock::parse_fault(f));
    } catch (const std::invalid_argument& e) {
      throw cli::UsageError(std::string("--fault: ") + e.what());
    }
  }
  std::unique_ptr<PlannedFaults> planned;
  try {
    planned = std::make_unique<PlannedFaults>(o.device, faults);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: fault plan: %s\n", e.what());
    return cli::kUsage;
  }
  std::unique_ptr<can::Transport> bus;
  try {
    bus = can::open_transport(o.transport);
  } catch (const can::TransportError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return cli::kUsage;
  }
  mock::RunOptions ro;
  ro.duration_s = o.duration;
  ro.log_path = o.log;
  if (ro.log_path.empty()) {
    if (const char* dir = std::getenv("RIG_LOG_DIR"); dir != nullptr && *dir != '\0') {
      ro.log_path = std::string(dir) + "/dbw_bus.log";
    }
  }
  ro.print_state = o.print_state;
  mock::MockEcu ecu(protocol, std::move(faults), o.seed);
  planned->observe(ecu, protocol, ro);
  std::fprintf(stderr, "mock paravan: %s, protocol %s (hash %s)%s%s\n", bus->name().c_str(),
               protocol.mapping_path().c_str(), protocol.config_hash().c_str(), ro.log_path.empty() ? "" : ", log ",
               ro.log_path.c_str());
  const auto r = mock::run_mock(ecu, *bus, ro);
  const auto& c = ecu.counters();
  std::fprintf(stderr, "mock paravan: rx %llu (e2e errors %llu), tx %llu (dropped %llu), pu timeouts %llu, logged %llu\n",
               static_cast<unsigned long long>(c.rx_frames), static_cast<unsigned long long>(c.rx_e2e_errors),
               static_cast<unsigned long long>(c.tx_frames), static_cast<unsigned long long>(c.tx_dropped),
               static_cast<unsigned long long>(c.pu_timeouts), static_cast<unsigned long long>(r.logged));
  return cli::kOk;
}

}  // namespace

void register_mock_cli(CLI::App& mock, cli::Context& ctx) {
  auto o = std::make_shared<MockOptions>();
  auto* p = mock.add_subcommand("paravan", "mock Paravan ECU + vehicle model on a CAN transport");
  p->add_option("--transport", o->transport,
                "bus: unix-listen:PATH (default, the bridge connects with unix:PATH), socketcan:IFACE, fd:N");
  p->add_option("--config", o->config, "protocol mapping YAML (default: config/dbw/paravan_ref.yaml)");
  p->add_option("--log", o->log, "write every frame on the bus (both directions) as candump -L; default $RIG_LOG_DIR/dbw_bus.log");
  p->add_option("--fault", o->faults, "loss=P | bad-crc | stuck-counter | override | ecu-fault | bus-off | no-status, each [@START_S][+DURATION_S]");
  p->add_option("--duration", o->duration, "seconds to run (0 = until Ctrl-C)")->check(CLI::NonNegativeNumber);
  p->add_option("--seed", o->seed, "random seed for frame loss");
  p->add_option("--device", o->device, "its name in a `rig chaos` fault plan (RIG_CHAOS_DIR)")->capture_default_str();
  p->add_flag("--print-state", o->print_state, "one JSON line per second with the vehicle state");
  p->callback([o, &ctx] { ctx.exit_code = run_mock_paravan(*o); });
}

}  // namespace sensor_rig::dbw
