// Fault plan / --fault specs -> the mock LIDAR's faults (see replay_faults.hpp).
#include "replay_faults.hpp"

#include <stdexcept>

#include "sensor_rig/common/cli_context.hpp"

namespace sensor_rig::lidar {
namespace {

constexpr std::uint64_t kSpecIdBase = 1'000'000;  // --fault ids beside a plan's (which count from 1)

std::string detail_of(const faults::FaultEvent& e) {
  std::string d;
  for (const auto& [k, v] : e.params) d += (d.empty() ? "" : ",") + k + "=" + v;
  return d;
}

// The kinds that act once, on one packet (or one burst) at the first data packet at or after their time.
bool one_shot(const std::string& kind) {
  return kind == "lidar.reorder" || kind == "lidar.duplicate_late" || kind == "lidar.loss_burst" || kind == "lidar.corrupt";
}

// `planned`: a campaign plan's event (absolute times, shared by every run of this mock); a --fault
// spec's times count from this run's start.
void add(ReplayFaults& out, const faults::FaultEvent& e, Nanos at_mono, const ReplayFaultInput& in,
         const std::optional<mock::PacketFields>& fields, bool planned) {
  const Nanos dur = static_cast<Nanos>(e.duration_s * 1e9);
  // A plan's fault whose time came before this run began belongs to the run that was alive then (a
  // mock restarted after host.kill_mock reads the same plan): a one-shot one, or one already over, is
  // not this run's to inject (a restarted mock fired its predecessor's loss bursts again); one still
  // on is injected for what is left of it. The truth record says which (truth_stream.hpp).
  const bool before_start = planned && at_mono < in.start_mono_ns;
  const bool over = before_start && (one_shot(e.kind) || dur <= 0 || at_mono + dur <= in.start_mono_ns);
  if (over) {
    if (e.kind.rfind("lidar.", 0) != 0 && e.kind != "host.network_delay") return;  // not the mock's
    const Nanos v_from = at_mono + in.mono_to_vehicle_ns;
    out.notes.push_back(mock::FaultNote{e.id, e.kind, v_from, v_from + dur, detail_of(e), true, false});
    return;
  }
  const Nanos v_from = at_mono + in.mono_to_vehicle_ns, v_until = v_from + dur;
  const Nanos o_from = at_mono - in.first_deadline_mono_ns, o_until = o_from + dur;
  using SK = mock::SensorFault::Kind;
  using NK = mock::NetFault::Kind;
  const auto sensor = [&](SK k) {
    if (!fields) throw std::invalid_argument(e.kind + ": a capture replay cannot do what the sensor itself does (use --synthetic)");
    mock::SensorFault f{e.id, k, v_from, v_until, e.number("rpm"), e.number("from_deg"), e.number("to_deg")};
    out.sensor.push_back(f);
  };
  const auto net = [&](NK k) {
    mock::NetFault f;
    f.id = e.id;
    f.kind = k;
    f.from_ns = o_from;
    f.until_ns = o_until;
    return f;
  };
  if (e.kind == "lidar.reorder") {
    auto f = net(NK::kReorder);
    f.n = static_cast<int>(e.number("n", 1));
    f.hold_ns = static_cast<Nanos>(e.number("ms") * 1e6);
    if (f.n < 1 && f.hold_ns <= 0) throw std::invalid_argument("lidar.reorder: n must be >= 1 (or ms > 0)");
    out.network.push_back(f);
  } else if (e.kind == "lidar.duplicate_late") {
    auto f = net(NK::kDuplicateLate);
    f.n = static_cast<int>(e.number("n", 5));
    out.network.push_back(f);
  } else if (e.kind == "lidar.loss_burst") {
    auto f = net(NK::kLossBurst);
    f.packets = static_cast<int>(e.number("packets", 10));
    f.at_cut = e.number("at_cut") != 0;
    if (f.packets < 1) throw std::invalid_argument("lidar.loss_burst: packets must be >= 1");
    out.network.push_back(f);
  } else if (e.kind == "lidar.corrupt") {
    auto f = net(NK::kCorrupt);
    const std::string name = e.text("field", "byte");
    const auto field = mock::packet_field_from_name(name);
    if (!field) throw std::invalid_argument("lidar.corrupt: unknown field '" + name + "' (time, azimuth, frame_id, column_status, udp_seq, byte)");
    const long offset = static_cast<long>(e.number("offset", -1));
    if (*field == mock::PacketField::kByte) {
      f.random_byte = offset < 0;
      if (fields) f.field = fields->locate(*field, offset);
      else f.field = mock::FieldBytes{offset < 0 ? 0 : static_cast<std::size_t>(offset), 1};
    } else {
      if (!fields) throw std::invalid_argument("lidar.corrupt field=" + name + ": a capture replay knows no fields (use field=byte)");
      f.field = fields->locate(*field, offset);
    }
    out.network.push_back(f);
  } else if (e.kind == "host.network_delay") {
    auto f = net(NK::kDelay);
    f.delay_ns = static_cast<Nanos>(e.number("ms", 50) * 1e6);
    f.jitter_ns = static_cast<Nanos>(e.number("jitter_ms", 0) * 1e6);
    if (f.delay_ns < 0 || f.jitter_ns < 0) throw std::invalid_argument("host.network_delay: ms and jitter_ms must be >= 0");
    out.network.push_back(f);
  } else if (e.kind == "lidar.restart") {
    sensor(SK::kRestart);
  } else if (e.kind == "lidar.stuck_azimuth") {
    sensor(SK::kStuckAzimuth);
  } else if (e.kind == "lidar.rpm_change") {
    sensor(SK::kRpmChange);
  } else if (e.kind == "lidar.blind_sector") {
    sensor(SK::kBlindSector);
  } else if (e.kind == "lidar.second_sensor") {
    sensor(SK::kSecondSensor);
  } else {
    return;  // the host's other faults are the campaign's (rig chaos), not the mock's
  }
  out.notes.push_back(mock::FaultNote{e.id, e.kind, v_from, v_until, detail_of(e), before_start, before_start});
}

}  // namespace

ReplayFaults replay_faults(const ReplayFaultInput& in, const std::optional<mock::PacketFields>& fields) {
  ReplayFaults out;
  try {
    if (!in.plan_path.empty()) {
      const faults::Plan plan = faults::read_plan(in.plan_path);
      for (const auto& e : plan.for_device(in.device))
        add(out, e, plan.epoch_mono_ns + static_cast<Nanos>(e.at_s * 1e9), in, fields, true);
    }
    std::vector<faults::FaultSpec> specs;
    for (const auto& s : in.specs) {
      specs.push_back(faults::parse_spec(s));
      const auto cls = faults::find_kind(specs.back().kind)->device_class;
      if (cls != faults::DeviceClass::kLidar && specs.back().kind != "host.network_delay")
        throw std::invalid_argument("'" + s + "': a LIDAR mock takes lidar.* faults and host.network_delay");
      if (specs.back().device.empty()) specs.back().device = in.device;
    }
    const std::vector<faults::Device> devices{{in.device, faults::DeviceClass::kLidar}};
    for (auto e : faults::expand(specs, devices, in.horizon_s)) {
      if (e.device != in.device) continue;  // aimed at another device
      e.id += kSpecIdBase;
      add(out, e, in.start_mono_ns + static_cast<Nanos>(e.at_s * 1e9), in, fields, false);
    }
  } catch (const std::invalid_argument& e) {
    throw cli::UsageError(e.what());
  } catch (const std::runtime_error& e) {
    throw cli::UsageError(std::string("--fault-plan: ") + e.what());
  }
  return out;
}

}  // namespace sensor_rig::lidar
