#include "sensor_rig/common/fault_plan.hpp"

#include <algorithm>
#include <cctype>
#include <array>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <stdexcept>

namespace sensor_rig::faults {
namespace {

using DC = DeviceClass;

// The vocabulary. Parameters are NAME=DEFAULT, comma separated; the default duration is what a spec
// without '+' gets (0 = the fault touches one unit: a packet, a frame).
constexpr std::array<KindInfo, 33> kKinds{{
    // LIDAR: what a real sensor and its network do to a packet stream.
    {"lidar.reorder", DC::kLidar, "n=1,ms=0", 0, "one packet sent n positions (or ms) after its successors", "n=1..12,ms=0|0|2..30"},
    {"lidar.duplicate_late", DC::kLidar, "n=5", 0, "one packet sent again n packets later", "n=1..30"},
    {"lidar.loss_burst", DC::kLidar, "packets=10,at_cut=0", 0, "packets consecutive packets lost (at_cut=1: straddling a scan cut)", "packets=1..400,at_cut=0|1"},
    {"lidar.corrupt", DC::kLidar, "field=byte,offset=-1", 0,
     "one packet with one field changed: time, azimuth, frame_id, column_status, udp_seq or byte (offset -1 = random)", "field=time|azimuth|frame_id|column_status|udp_seq|byte"},
    {"lidar.second_sensor", DC::kLidar, "", 2, "a second sensor of the same model sends to the same port", "+1..5"},
    {"lidar.restart", DC::kLidar, "", 1, "the sensor is silent, then comes back with its clock and ids jumped", "+0.3..4"},
    {"lidar.stuck_azimuth", DC::kLidar, "", 0.5, "the azimuth field stops moving (encoder fault)", "+0.1..2"},
    {"lidar.rpm_change", DC::kLidar, "rpm=300", 2, "the rotor runs at another speed", "rpm=300|900|1200,+1..8"},
    {"lidar.blind_sector", DC::kLidar, "from_deg=90,to_deg=180", 2, "no packets from a sector (restricted FOV)", "from_deg=0..359,to_deg=0..359,+1..8"},
    // Cameras (GigE Vision through Aravis).
    {"camera.never_answers", DC::kCamera, "", 0, "the camera never answers (whole run)", ""},
    {"camera.slow_open", DC::kCamera, "s=3", 0, "the camera answers only s seconds after the first attempt", "s=0.5..8"},
    {"camera.dies", DC::kCamera, "", 2, "the camera stops streaming and answering, then returns", "+0.3..6"},
    {"camera.ptp", DC::kCamera, "state=Master,tai_offset_s=37,step_ms=0", 3,
     "PTP state (Disabled, Listening, Uncalibrated, Slave, Master, Faulty) with a TAI offset and a clock step", "state=Initializing|Faulty|Disabled|Listening|Master|Slave|Uncalibrated|cold_start,tai_offset_s=37|37|0,step_ms=0|-1000..1000,+1..10"},
    {"camera.exposure_change", DC::kCamera, "us=8000", 0, "exposure time changed while streaming", "us=50..15000"},
    {"camera.auto_exposure", DC::kCamera, "", 3, "auto exposure on: exposure varies frame to frame", "+1..10"},
    {"camera.chunk_data", DC::kCamera, "payload=image", 3,
     "chunks (timestamp, exposure) appended to each frame: payload=image (0x4001, image + chunks), chunk (0x0004, the image its first chunk) or multipart (0x000A: a chunk part, then the image part)", "payload=image|chunk|multipart,+1..10"},
    {"camera.packet_loss", DC::kCamera, "p=0.01,resend=1", 2, "GVSP packets lost (resend=1: the camera answers resends)", "p=0.001..0.05,resend=0|1,+0.5..5"},
    {"camera.padded_rows", DC::kCamera, "bytes=64", 2, "rows padded to a stride wider than width x bytes per pixel", "bytes=1..256,+0.5..5"},
    // USB cameras (V4L2).
    {"v4l2.stamp_mode", DC::kV4l2, "mode=eof", 3, "buffer timestamps at end of frame (eof) or start of exposure (soe)", "mode=eof|soe,+1..10"},
    {"v4l2.sequence_gap", DC::kV4l2, "n=3", 0, "n frames skipped by the device (sequence jumps)", "n=1..12"},
    {"v4l2.disconnect", DC::kV4l2, "", 1, "the device disappears (ENODEV), then returns", "+0.2..4"},
    // Drive-by-wire (the mock Paravan ECU's faults, rig mock paravan --fault).
    {"dbw.loss", DC::kDbw, "p=0.1", 2, "frames lost on the bus, both directions", "p=0.01..0.5,+0.5..4"},
    {"dbw.bad_crc", DC::kDbw, "", 1, "ECU status frames with a wrong CRC", "+0.2..3"},
    {"dbw.stuck_counter", DC::kDbw, "", 1, "ECU status frames with a frozen alive counter", "+0.2..3"},
    {"dbw.override", DC::kDbw, "", 1, "the driver takes over (steering torque)", "+0.2..3"},
    {"dbw.ecu_fault", DC::kDbw, "", 1, "the ECU reports a fault", "+0.2..3"},
    {"dbw.bus_off", DC::kDbw, "", 1, "the bus goes off: nothing passes", "+0.2..3"},
    {"dbw.no_status", DC::kDbw, "", 1, "the ECU stops sending status frames", "+0.2..3"},
    // The host under the rig.
    {"host.clock_step", DC::kHost, "ms=-500", 5, "CLOCK_REALTIME stepped by ms under the rig, stepped back when the fault ends", "ms=-37000|-2000|-500|-20|-2|2|20|500|2000|37000,+1..10"},
    {"host.cpu_hog", DC::kHost, "threads=2", 3, "busy threads competing for the cores", "threads=1..4,+1..8"},
    {"host.kill_mock", DC::kHost, "restart_s=1", 0, "a mock device process killed (SIGKILL), restarted restart_s later", "restart_s=0.1..3"},
    {"host.stall_mock", DC::kHost, "ms=300", 0, "a mock device process stopped (SIGSTOP) for ms", "ms=20..2000"},
    {"host.network_delay", DC::kHost, "ms=50,jitter_ms=0", 1,
     "the devices' network held back by ms +-jitter_ms: netem on lo (LIDAR UDP only, may reorder), else in the mocks, "
     "in order, nothing lost: LIDAR datagrams, GigE fake cameras' GVSP, the mock ECU's CAN frames (not V4L2, not the "
     "in-process Aravis fakes); camera stamps must not move, the dbw bridge's ECU watchdog trips only past ecu_timeout_ms", "ms=1..150,jitter_ms=0|1..40,+0.5..30"},
}};

std::map<std::string, std::string> default_params(const KindInfo& k) {
  std::map<std::string, std::string> out;
  std::string_view rest = k.params;
  while (!rest.empty()) {
    const auto comma = rest.find(',');
    const std::string_view item = rest.substr(0, comma);
    const auto eq = item.find('=');
    out.emplace(std::string(item.substr(0, eq)), std::string(item.substr(eq + 1)));
    rest = comma == std::string_view::npos ? std::string_view{} : rest.substr(comma + 1);
  }
  return out;
}

double parse_seconds(std::string_view text, std::string_view what, std::string_view spec) {
  double v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc{} || end != text.data() + text.size() || !std::isfinite(v) || v < 0)
    throw std::invalid_argument("'" + std::string(spec) + "': " + std::string(what) + " '" + std::string(text) +
                                "' is not a number of seconds >= 0");
  return v;
}

// Parameters that name one of a few choices: a misspelt one is an error here, not another fault
// injected in silence (camera.chunk_data:payload=multipat was the 0x4001 payload).
struct Choices {
  std::string_view kind, param, values;  // values: '|'-separated
};
constexpr Choices kChoices[] = {
    {"camera.chunk_data", "payload", "image|chunk|multipart"},
    {"camera.ptp", "state", "Initializing|Faulty|Disabled|Listening|Master|Slave|Uncalibrated|cold_start"},
    {"v4l2.stamp_mode", "mode", "eof|soe"},
    {"lidar.corrupt", "field", "time|azimuth|frame_id|column_status|udp_seq|byte"},
};

void check_choice(std::string_view spec, std::string_view kind, std::string_view param, std::string_view value) {
  for (const auto& c : kChoices) {
    if (c.kind != kind || c.param != param) continue;
    for (std::string_view rest = c.values; !rest.empty();) {
      const auto bar = rest.find('|');
      const auto choice = rest.substr(0, bar);
      if (same_choice(choice, value)) return;
      rest = bar == std::string_view::npos ? std::string_view{} : rest.substr(bar + 1);
    }
    std::string one_of(c.values);
    std::replace(one_of.begin(), one_of.end(), '|', ',');
    throw std::invalid_argument("'" + std::string(spec) + "': " + std::string(param) + "='" + std::string(value) +
                                "' is not one of " + one_of);
  }
}

// A draw's text: one value, or LO..HI drawn uniformly (whole numbers when both ends are).
std::string draw_alternative(std::string_view kind, std::string_view alt, std::mt19937_64& rng, bool whole_allowed = true) {
  const auto dots = alt.find("..");
  if (dots == std::string_view::npos) return std::string(alt);
  const std::string_view lo_text = alt.substr(0, dots), hi_text = alt.substr(dots + 2);
  double lo = 0, hi = 0;
  const auto a = std::from_chars(lo_text.data(), lo_text.data() + lo_text.size(), lo);
  const auto b = std::from_chars(hi_text.data(), hi_text.data() + hi_text.size(), hi);
  if (a.ec != std::errc{} || a.ptr != lo_text.data() + lo_text.size() || b.ec != std::errc{} ||
      b.ptr != hi_text.data() + hi_text.size() || !(lo <= hi))
    throw std::invalid_argument(std::string(kind) + ": draw '" + std::string(alt) + "' is not LO..HI with LO <= HI");
  const bool whole = whole_allowed && lo_text.find('.') == std::string_view::npos && hi_text.find('.') == std::string_view::npos;
  if (whole)
    return std::to_string(std::uniform_int_distribution<long long>(std::llround(lo), std::llround(hi))(rng));
  const double v = std::uniform_real_distribution<double>(lo, hi)(rng);
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);  // what the plan file and the truth records say
  return buf;
}

// The next of the markers that end a spec's kind/params part.
std::size_t next_marker(std::string_view s, std::size_t from) { return s.find_first_of("@+~>", from); }

}  // namespace

std::string_view to_string(DeviceClass c) noexcept {
  switch (c) {
    case DC::kLidar: return "lidar";
    case DC::kCamera: return "camera";
    case DC::kV4l2: return "v4l2";
    case DC::kDbw: return "dbw";
    case DC::kHost: return "host";
  }
  return "?";
}

std::span<const KindInfo> kinds() { return kKinds; }

bool same_choice(std::string_view a, std::string_view b) noexcept {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(), [](char x, char y) {
    return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
  });
}

const KindInfo* find_kind(std::string_view name) noexcept {
  for (const auto& k : kKinds)
    if (k.name == name) return &k;
  return nullptr;
}

FaultSpec parse_spec(std::string_view spec) {
  FaultSpec s;
  const std::size_t head_end = next_marker(spec, 0);
  const std::string_view head = spec.substr(0, head_end);
  const std::size_t colon = head.find(':');
  s.kind = std::string(head.substr(0, colon));
  const KindInfo* k = find_kind(s.kind);
  if (k == nullptr) {
    std::string known;
    for (const auto& kk : kKinds) known += (known.empty() ? "" : ", ") + std::string(kk.name);
    throw std::invalid_argument("'" + std::string(spec) + "': unknown fault kind '" + s.kind + "' (known: " + known + ")");
  }
  s.params = default_params(*k);
  s.duration_s = k->default_duration_s;
  std::string_view rest = colon == std::string_view::npos ? std::string_view{} : head.substr(colon + 1);
  while (!rest.empty()) {
    const auto next = rest.find(':');
    const std::string_view item = rest.substr(0, next);
    const auto eq = item.find('=');
    if (eq == std::string_view::npos || eq == 0)
      throw std::invalid_argument("'" + std::string(spec) + "': parameter '" + std::string(item) + "' is not NAME=VALUE");
    const std::string name(item.substr(0, eq));
    if (!s.params.contains(name))
      throw std::invalid_argument("'" + std::string(spec) + "': " + s.kind + " takes no parameter '" + name +
                                  "' (it takes: " + (k->params.empty() ? std::string("none") : std::string(k->params)) + ")");
    s.params[name] = std::string(item.substr(eq + 1));
    check_choice(spec, s.kind, name, s.params[name]);
    rest = next == std::string_view::npos ? std::string_view{} : rest.substr(next + 1);
  }
  std::size_t pos = head_end;
  while (pos != std::string_view::npos && pos < spec.size()) {
    const char marker = spec[pos];
    const std::size_t end = next_marker(spec, pos + 1);
    const std::string_view value = spec.substr(pos + 1, end == std::string_view::npos ? std::string_view::npos : end - pos - 1);
    switch (marker) {
      case '@': s.start_s = parse_seconds(value, "start", spec); break;
      case '+': s.duration_s = parse_seconds(value, "duration", spec); break;
      case '~':
        s.every_s = parse_seconds(value, "period", spec);
        if (s.every_s <= 0) throw std::invalid_argument("'" + std::string(spec) + "': a period must be > 0 s");
        break;
      case '>':
        if (value.empty()) throw std::invalid_argument("'" + std::string(spec) + "': '>' needs a device name");
        s.device = std::string(value);
        break;
      default: break;
    }
    pos = end;
  }
  return s;
}

std::string to_string(const FaultSpec& s) {
  std::ostringstream o;
  o << s.kind;
  for (const auto& [k, v] : s.params) o << ':' << k << '=' << v;
  o << '@' << s.start_s << '+' << s.duration_s;
  if (s.every_s > 0) o << '~' << s.every_s;
  if (!s.device.empty()) o << '>' << s.device;
  return o.str();
}

double FaultEvent::number(const std::string& name, double fallback) const {
  const auto it = params.find(name);
  if (it == params.end()) return fallback;
  double v = 0;
  const auto [end, ec] = std::from_chars(it->second.data(), it->second.data() + it->second.size(), v);
  if (ec != std::errc{} || end != it->second.data() + it->second.size())
    throw std::invalid_argument(kind + ": parameter " + name + "='" + it->second + "' is not a number");
  return v;
}

std::string FaultEvent::text(const std::string& name, const std::string& fallback) const {
  const auto it = params.find(name);
  return it == params.end() ? fallback : it->second;
}

DeviceClass FaultEvent::device_class() const {
  const KindInfo* k = find_kind(kind);
  if (k == nullptr) throw std::invalid_argument("unknown fault kind '" + kind + "'");
  return k->device_class;
}

std::vector<FaultEvent> expand(std::span<const FaultSpec> specs, std::span<const Device> devices, double horizon_s) {
  std::vector<FaultEvent> out;
  for (const auto& s : specs) {
    const KindInfo* k = find_kind(s.kind);
    if (k == nullptr) throw std::invalid_argument("unknown fault kind '" + s.kind + "'");
    std::vector<std::string> targets;
    if (k->device_class == DC::kHost && s.device.empty()) {
      targets.emplace_back();  // the host: no device (kill_mock picks one when it runs)
    } else {
      for (const auto& d : devices)
        if (d.device_class == k->device_class && (s.device.empty() || s.device == d.name)) targets.push_back(d.name);
      if (targets.empty() && !s.device.empty()) targets.push_back(s.device);  // host faults aimed at one device
    }
    for (const auto& dev : targets) {
      for (double t = s.start_s; t < horizon_s; t += s.every_s) {
        out.push_back(FaultEvent{0, s.kind, dev, t, s.duration_s, s.params});
        if (s.every_s <= 0) break;
      }
    }
  }
  std::stable_sort(out.begin(), out.end(), [](const FaultEvent& a, const FaultEvent& b) { return a.at_s < b.at_s; });
  for (std::size_t i = 0; i < out.size(); ++i) out[i].id = i + 1;
  return out;
}

Drawn draw(const KindInfo& kind, std::mt19937_64& rng) {
  Drawn d{default_params(kind), kind.default_duration_s};
  std::string_view rest = kind.draws;
  while (!rest.empty()) {
    const auto comma = rest.find(',');
    const std::string_view item = rest.substr(0, comma);
    rest = comma == std::string_view::npos ? std::string_view{} : rest.substr(comma + 1);
    const bool duration = !item.empty() && item.front() == '+';
    const auto eq = item.find('=');
    if (!duration && (eq == std::string_view::npos || eq == 0))
      throw std::invalid_argument(std::string(kind.name) + ": draw '" + std::string(item) + "' is not NAME=ALT|ALT or +LO..HI");
    const std::string name(duration ? std::string_view{} : item.substr(0, eq));
    if (!duration && !d.params.contains(name))
      throw std::invalid_argument(std::string(kind.name) + ": draws '" + name + "', which is none of its parameters");
    std::vector<std::string_view> alts;
    for (std::string_view a = item.substr(duration ? 1 : eq + 1); !a.empty();) {
      const auto bar = a.find('|');
      alts.push_back(a.substr(0, bar));
      a = bar == std::string_view::npos ? std::string_view{} : a.substr(bar + 1);
    }
    if (alts.empty()) throw std::invalid_argument(std::string(kind.name) + ": draw '" + std::string(item) + "' has no value");
    const std::string_view alt = alts[std::uniform_int_distribution<std::size_t>(0, alts.size() - 1)(rng)];
    const std::string value = draw_alternative(kind.name, alt, rng, !duration);  // a duration is never whole seconds only
    if (duration) {
      d.duration_s = parse_seconds(value, "drawn duration", kind.draws);
    } else {
      check_choice(kind.draws, kind.name, name, value);
      d.params[name] = value;
    }
  }
  return d;
}

std::vector<FaultEvent> random_campaign(std::span<const std::string> allowed, std::span<const Device> devices,
                                        double rate_per_min, double horizon_s, std::uint64_t seed, bool draw_params) {
  std::mt19937_64 rng(seed);
  // The kinds a device here can take, in the vocabulary's order (a stable plan for a seed).
  std::vector<const KindInfo*> pool;
  for (const auto& k : kKinds) {
    if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), std::string(k.name)) == allowed.end()) continue;
    const bool process_kind = k.name == "host.kill_mock" || k.name == "host.stall_mock";
    const bool have = process_kind ? std::any_of(devices.begin(), devices.end(), [](const Device& d) { return d.own_process; })
                      : k.device_class == DC::kHost
                          ? true
                          : std::any_of(devices.begin(), devices.end(), [&](const Device& d) { return d.device_class == k.device_class; });
    if (have) pool.push_back(&k);
  }
  if (pool.empty() || horizon_s <= 0 || rate_per_min <= 0) return {};
  auto device_for = [&](const KindInfo& k) -> std::string {
    std::vector<const Device*> of_class;
    for (const auto& d : devices)
      if (d.device_class == k.device_class) of_class.push_back(&d);
    if (k.name == "host.kill_mock" || k.name == "host.stall_mock") {  // aimed at one mock process
      for (const auto& d : devices)
        if (d.own_process) of_class.push_back(&d);
      if (of_class.empty()) return {};
    }
    if (of_class.empty()) return {};
    return of_class[std::uniform_int_distribution<std::size_t>(0, of_class.size() - 1)(rng)]->name;
  };
  // Leave the first and last seconds quiet: the rig starts and ends without a fault.
  const double lo = std::min(2.0, horizon_s * 0.1), hi = std::max(lo, horizon_s - std::min(3.0, horizon_s * 0.1));
  // A drawn duration is at most a quarter of the horizon (a short campaign is not one long fault),
  // or the kind's default where that is longer.
  auto event_of = [&](const KindInfo& k, const std::string& device, double at) {
    if (!draw_params) return FaultEvent{0, std::string(k.name), device, at, k.default_duration_s, default_params(k)};
    Drawn d = draw(k, rng);
    d.duration_s = std::min(d.duration_s, std::max(k.default_duration_s, horizon_s / 4));
    return FaultEvent{0, std::string(k.name), device, at, d.duration_s, std::move(d.params)};
  };
  std::vector<FaultEvent> out;
  // Every kind once, at random times (shuffled order), then Poisson arrivals of random kinds.
  std::vector<const KindInfo*> order = pool;
  std::shuffle(order.begin(), order.end(), rng);
  std::uniform_real_distribution<double> when(lo, hi);
  for (const KindInfo* k : order) {
    if (k->name == "camera.never_answers") {  // a whole-run fault: from the start
      out.push_back(FaultEvent{0, std::string(k->name), device_for(*k), 0.0, 0.0, default_params(*k)});
      continue;
    }
    const std::string device = device_for(*k);
    const double at = when(rng);
    out.push_back(event_of(*k, device, at));
  }
  std::exponential_distribution<double> gap(rate_per_min / 60.0);
  std::vector<const KindInfo*> repeatable;
  for (const KindInfo* k : pool)
    if (k->name != "camera.never_answers") repeatable.push_back(k);
  for (double t = lo + gap(rng); t < hi && !repeatable.empty(); t += gap(rng)) {
    const KindInfo* k = repeatable[std::uniform_int_distribution<std::size_t>(0, repeatable.size() - 1)(rng)];
    out.push_back(event_of(*k, device_for(*k), t));
  }
  std::stable_sort(out.begin(), out.end(), [](const FaultEvent& a, const FaultEvent& b) { return a.at_s < b.at_s; });
  for (std::size_t i = 0; i < out.size(); ++i) out[i].id = i + 1;
  return out;
}

std::vector<FaultEvent> Plan::for_device(const std::string& device) const {
  std::vector<FaultEvent> out;
  for (const auto& e : events)
    if (e.device == device || (e.device.empty() && find_kind(e.kind) && find_kind(e.kind)->device_class == DC::kHost))
      out.push_back(e);
  return out;
}

void write_plan(const std::string& path, const Plan& plan) {
  std::ofstream out(path, std::ios::trunc);
  if (!out) throw std::runtime_error("cannot write fault plan " + path);
  out << nlohmann::json{{"fault_plan", 1}, {"epoch_mono_ns", plan.epoch_mono_ns}}.dump() << '\n';
  for (const auto& e : plan.events) {
    nlohmann::json j{{"id", e.id}, {"kind", e.kind}, {"device", e.device}, {"at_s", e.at_s}, {"duration_s", e.duration_s},
                     {"params", e.params}};
    out << j.dump() << '\n';
  }
  out.close();
  if (!out) throw std::runtime_error("cannot write fault plan " + path);
}

Plan read_plan(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read fault plan " + path);
  Plan plan;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty()) continue;
    const std::string where = path + ":" + std::to_string(n) + ": ";
    try {
      const auto j = nlohmann::json::parse(line);
      if (n == 1) {
        if (!j.contains("fault_plan")) throw std::runtime_error("not a fault plan (no \"fault_plan\" header)");
        plan.epoch_mono_ns = j.value("epoch_mono_ns", Nanos{0});
        continue;
      }
      FaultEvent e;
      e.id = j.at("id").get<std::uint64_t>();
      e.kind = j.at("kind").get<std::string>();
      if (find_kind(e.kind) == nullptr) throw std::runtime_error("unknown fault kind '" + e.kind + "'");
      e.device = j.value("device", std::string{});
      e.at_s = j.at("at_s").get<double>();
      e.duration_s = j.value("duration_s", 0.0);
      if (j.contains("params")) e.params = j.at("params").get<std::map<std::string, std::string>>();
      plan.events.push_back(std::move(e));
    } catch (const nlohmann::json::exception& ex) {
      throw std::runtime_error(where + ex.what());
    } catch (const std::runtime_error& ex) {
      throw std::runtime_error(where + ex.what());
    }
  }
  if (n == 0) throw std::runtime_error(path + ": empty fault plan");
  return plan;
}

std::string chaos_plan_path() {
  const char* dir = std::getenv("RIG_CHAOS_DIR");
  return dir == nullptr || *dir == '\0' ? std::string{} : std::string(dir) + "/plan.jsonl";
}

std::string chaos_truth_path(const std::string& device) {
  const char* dir = std::getenv("RIG_CHAOS_DIR");
  return dir == nullptr || *dir == '\0' ? std::string{} : std::string(dir) + "/truth/" + device + ".jsonl";
}

}  // namespace sensor_rig::faults
