// `rig lidar replay`: a mock LIDAR (SPEC §7). Sends a capture's UDP payloads (--pcap), a
// recording's raw LIDAR channel (--mcap FILE or a split recording's FOLDER, read by the opener the
// rig registers) or a synthetic sensor's packets (--synthetic MODEL, any of the seven models) to
// HOST:PORT at their own timing, scaled by --rate, optionally looping, with injected network faults.
// Position packets (port 8308 in a capture; GPRMC + PPS from the synthetic sensor) go to
// --position-port on the same host when given, else they are skipped. Ends with one summary line on
// stderr (and --json on stdout).
// --fault-plan / --fault: the fault vocabulary's events of --device; --truth: what it really did.

#include <cmath>
#include <cstring>
#include <filesystem>
#include <cstdio>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "lidar_commands.hpp"
#include "sensor_rig/common/cli.hpp"
#include "replay_faults.hpp"
#include "sensor_rig/lidar/decoder_files.hpp"
#include "sensor_rig/lidar/return_selection.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/thread_priority.hpp"
#include "sensor_rig/lidar/mock/phase_lock.hpp"
#include "sensor_rig/lidar/mock/replay.hpp"
#include "sensor_rig/lidar/mock/synthetic_factory.hpp"
#include "sensor_rig/lidar/mock/synthetic_ouster.hpp"
#include "sensor_rig/lidar/pcap_reader.hpp"
#include "sensor_rig/lidar/udp_sender.hpp"

namespace sensor_rig::lidar {
namespace {

struct ReplayCliOptions {
  std::string pcap;
  std::string mcap;        // a recording's raw channel (rig record --raw): a file or a split folder
  std::string mcap_topic;  // its topic, /sensors/lidar/NAME/packets
  mock::RecordingOpener open_recording;  // what reads it (the rig's, see register_replay_command)
  double delay_s = 0;      // the first packet this long after the start (subscribers match meanwhile)
  std::string synthetic;
  std::string to;
  double rate = 1.0;
  bool loop = false;
  double rpm = 600.0;
  std::optional<double> phase_lock;  // synthetic: rotor angle at every whole second
  ReturnSelection returns = ReturnSelection::kStrongest;
  std::string calibration;     // synthetic Velodyne / Hesai
  std::string metadata;        // synthetic Ouster: render this sensor
  std::string write_metadata;  // synthetic Ouster: write the metadata used
  int beams = 32;              // nominal synthetic Ouster
  std::string lidar_mode;
  std::string profile;
  int position_port = 0;
  double duration_s = 0.0;
  std::uint64_t count = 0;
  double drop = 0, corrupt = 0, truncate = 0, duplicate = 0, reorder = 0;
  double stall_ms = 0, stall_every_s = 0;
  std::uint64_t seed = 1;
  int send_buffer = 4 << 20;
  bool json = false;
  int rt_priority = 10;
  std::string device = "lidar";
  std::string truth;
  std::string fault_plan;
  std::vector<std::string> fault_specs;
};

// A mock sensor should keep hardware-like timing on a loaded machine: SCHED_FIFO at a low
// priority when permitted (root / CAP_SYS_NICE). The loop sleeps between packets (~10 % of a core
// for an HDL-32E), and the kernel's RT throttling bounds it anyway. Best effort.
void apply_rt_priority(int priority) {
  if (priority <= 0) return;
  if (const auto r = try_realtime_priority(priority); !r)
    log::debug("replay", "SCHED_FIFO not available (" + r.why_not + "), normal scheduling");
}

mock::SyntheticOptions synthetic_options(const ReplayCliOptions& o, std::uint16_t port, Nanos start_ns) {
  mock::SyntheticOptions s;
  s.model = o.synthetic;
  s.rpm = o.rpm;
  s.returns = o.returns;
  s.start_ns = start_ns;
  s.phase_lock_deg = o.phase_lock;
  try {
    apply_decoder_files(read_decoder_files(o.calibration, o.metadata), s);
  } catch (const DecoderFileError& e) {
    throw cli::UsageError(e.what());
  }
  s.ouster_beams = o.beams;
  s.ouster_mode = o.lidar_mode;
  s.ouster_profile = o.profile;
  if (port != 0) s.ouster_udp_port = port;
  return s;
}

// --write-metadata: the Ouster metadata the synthetic sensor renders with, for the driver.
void write_metadata(const ReplayCliOptions& o, std::uint16_t port) {
  if (!mock::is_ouster_model(o.synthetic))
    throw cli::UsageError("--write-metadata applies to the synthetic Ouster models (OS-LEGACY, OS)");
  std::string json;
  try {
    json = mock::metadata_json(mock::synthetic_ouster_metadata(synthetic_options(o, port, 0)));
  } catch (const std::invalid_argument& e) {
    throw cli::UsageError(e.what());
  }
  std::ofstream out(o.write_metadata, std::ios::binary | std::ios::trunc);
  out << json;
  out.close();
  if (!out) throw std::runtime_error("cannot write metadata " + o.write_metadata);
}

// What "dev" is in the truth record: the clock each vendor's packets carry.
std::string clock_of(const ReplayCliOptions& o) {
  if (o.synthetic.empty()) return "none (a capture or recording: units and acquisition unknown)";
  if (mock::is_ouster_model(o.synthetic)) return "sensor ns, PTP-synced (column timestamps)";
  if (o.synthetic.rfind("Pandar", 0) == 0) return "sensor UTC ns, us resolution (tail time moved to the first firing)";
  return "sensor us since the top of the hour, as ns";
}

// The stream to send, with its faults and truth record when asked for. Sets ro.start_monotonic_ns:
// when the first packet is due (a synthetic sensor's timeline is vehicle time, and its packets leave
// when their time comes), and ro.scheduled / ro.observer.
std::unique_ptr<mock::PacketStream> make_stream(const ReplayCliOptions& o, std::uint16_t port, mock::ReplayOptions& ro,
                                                std::unique_ptr<mock::TruthStream>& truth_stream) {
  // The synthetic sensor is built before the clock is read: its first packet may be due lead_ns
  // (2 ms) later, and building an Ouster's rays took 3-11 ms under a starting rig (its first 11
  // packets then left together, 16-18 ms late by its truth record, and the driver stamped that
  // scan from them: test_lidar_synthetic_rig).
  const mock::SyntheticOptions base = o.synthetic.empty() ? mock::SyntheticOptions{} : synthetic_options(o, port, 0);
  std::unique_ptr<mock::SyntheticSensor> sensor;
  if (!o.synthetic.empty()) {
    try {
      sensor = mock::make_synthetic_sensor(base, mock::Scene::standard());
    } catch (const std::invalid_argument& e) {
      throw cli::UsageError(e.what());
    }
  }
  const auto now = mock_clock_pair_now();  // vehicle time, also when restarted under a host step
  const Nanos mono_now = now.monotonic_ns;
  const Nanos vehicle_now = now.vehicle_ns;
  const bool faulted = !o.fault_plan.empty() || !o.fault_specs.empty();
  ReplayFaultInput fin{o.device, o.fault_plan, o.fault_specs, mono_now, 0, vehicle_now - mono_now,
                       o.duration_s > 0 ? o.duration_s : 86400.0};
  const truth::Header header{o.device, "lidar", o.synthetic.empty() ? std::string("capture") : o.synthetic,
                             "/sensors/lidar/" + o.device + "/points", "scan", clock_of(o)};
  const auto open_truth = [&] {
    if (!o.truth.empty() && std::filesystem::path(o.truth).has_parent_path())
      std::filesystem::create_directories(std::filesystem::path(o.truth).parent_path());
    return truth::open_if(o.truth, header);
  };
  if (!o.pcap.empty() || !o.mcap.empty()) {
    std::unique_ptr<mock::PacketStream> capture;
    try {
      if (!o.mcap.empty()) {
        if (!o.open_recording) throw std::runtime_error("this build reads no recordings (--mcap)");
        capture = o.open_recording(o.mcap, o.mcap_topic);
      } else {
        capture = std::make_unique<mock::PcapStream>(o.pcap);
      }
    } catch (const std::exception& e) {  // PcapError, McapError, no such channel
      throw std::runtime_error(std::string("cannot replay: ") + e.what());
    }
    if (!faulted && o.truth.empty()) return capture;
    ro.start_monotonic_ns = mono_now + ro.lead_ns;
    fin.first_deadline_mono_ns = ro.start_monotonic_ns;
    ReplayFaults f = replay_faults(fin, std::nullopt);
    ro.scheduled = std::move(f.network);
    truth_stream = std::make_unique<mock::TruthStream>(std::move(capture), open_truth(), std::move(f.notes));
    ro.observer = truth_stream.get();
    return nullptr;
  }
  // The sensor's clock is the host's (a PTP-synced sensor): each packet leaves when the vehicle
  // time it is complete at comes, the first lead_ns from now at the earliest, later when the rotor
  // must first reach its phase-locked angle.
  Nanos start = vehicle_now + ro.lead_ns - sensor->first_packet_offset_ns();
  if (o.phase_lock) start = mock::phase_locked_start_ns(*sensor, start, *o.phase_lock);
  sensor->set_start_ns(start);
  ro.start_monotonic_ns = mono_now + (start + sensor->first_packet_offset_ns() - vehicle_now);
  if (!faulted && o.truth.empty()) return std::make_unique<mock::SyntheticStream>(std::move(sensor));

  fin.first_deadline_mono_ns = ro.start_monotonic_ns;
  ReplayFaults f = replay_faults(fin, mock::PacketFields(*sensor));
  ro.scheduled = std::move(f.network);
  // The sensor is made again when a fault restarts it or changes its speed: same options.
  mock::SensorFactory make = [base](const mock::SensorSetup& s) {
    mock::SyntheticOptions so = base;
    so.start_ns = s.start_ns;
    so.rpm = s.rpm;
    so.start_rotor_deg = s.start_rotor_deg;
    so.boot = s.boot;
    so.phase_lock_deg.reset();  // placed by start_ns, not locked again
    return mock::make_synthetic_sensor(so, mock::Scene::standard());
  };
  std::unique_ptr<mock::FaultySensor> faulty;
  try {
    faulty = std::make_unique<mock::FaultySensor>(make, mock::SensorSetup{start, o.rpm, 0.0, 0}, std::move(f.sensor),
                                                  std::move(sensor));
  } catch (const std::invalid_argument& e) {
    throw cli::UsageError(e.what());
  }
  truth_stream = std::make_unique<mock::TruthStream>(std::move(faulty), open_truth(), std::move(f.notes));
  ro.observer = truth_stream.get();
  return nullptr;
}

std::string json_line(const mock::ReplayStats& s) {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "{\"sent\":%llu,\"sent_data\":%llu,\"sent_position\":%llu,\"read\":%llu,\"elapsed_s\":%.3f,"
                "\"late\":%llu,\"loops\":%llu,\"send_errors\":%llu,\"dropped\":%llu,\"corrupted\":%llu,"
                "\"truncated\":%llu,\"duplicated\":%llu,\"reordered\":%llu,\"stalls\":%llu,\"max_late_ms\":%.3f}",
                static_cast<unsigned long long>(s.sent), static_cast<unsigned long long>(s.sent_data),
                static_cast<unsigned long long>(s.sent_position), static_cast<unsigned long long>(s.read),
                static_cast<double>(s.elapsed_ns) * 1e-9, static_cast<unsigned long long>(s.late),
                static_cast<unsigned long long>(s.loops), static_cast<unsigned long long>(s.send_errors),
                static_cast<unsigned long long>(s.faults.dropped),
                static_cast<unsigned long long>(s.faults.corrupted),
                static_cast<unsigned long long>(s.faults.truncated),
                static_cast<unsigned long long>(s.faults.duplicated),
                static_cast<unsigned long long>(s.faults.reordered),
                static_cast<unsigned long long>(s.faults.stalls), static_cast<double>(s.max_late_ns) * 1e-6);
  return buf;
}

int run_replay_command(const ReplayCliOptions& o) {
  const int sources = int{!o.pcap.empty()} + int{!o.mcap.empty()} + int{!o.synthetic.empty()};
  if (sources != 1) throw cli::UsageError("give exactly one of --pcap FILE, --mcap FILE|FOLDER or --synthetic MODEL");
  if (!o.mcap.empty() && o.mcap_topic.empty()) throw cli::UsageError("--mcap needs --mcap-topic /sensors/lidar/NAME/packets");
  if (o.mcap.empty() && !o.mcap_topic.empty()) throw cli::UsageError("--mcap-topic applies to --mcap");
  if (!(o.rate > 0.0 && std::isfinite(o.rate))) throw cli::UsageError("--rate must be > 0");
  if (o.loop && !o.synthetic.empty()) throw cli::UsageError("--loop applies to --pcap and --mcap (a synthetic sensor never ends)");
  if (o.synthetic.empty() && !(o.calibration.empty() && o.metadata.empty() && o.write_metadata.empty()))
    throw cli::UsageError("--calibration, --metadata and --write-metadata apply to --synthetic");
  if (o.synthetic.empty() && o.phase_lock) throw cli::UsageError("--phase-lock applies to --synthetic (a capture keeps its own phase)");
  if (o.phase_lock && o.rate != 1.0) throw cli::UsageError("--phase-lock needs --rate 1 (the lock is to real seconds)");
  if (o.to.empty()) {
    if (o.write_metadata.empty()) throw cli::UsageError("--to HOST:PORT is required");
    write_metadata(o, 0);  // only the metadata: nothing to send
    return cli::kOk;
  }
  Endpoint data;
  try {
    data = parse_endpoint(o.to);
  } catch (const std::invalid_argument& e) {
    throw cli::UsageError(std::string("--to: ") + e.what());
  }
  if (data.port == 0) throw cli::UsageError("--to needs a port other than 0");

  mock::ReplayOptions ro;
  ro.rate = o.rate;
  ro.loop = o.loop;
  ro.duration_ns = static_cast<Nanos>(o.duration_s * 1e9);
  ro.max_packets = o.count;
  if (o.delay_s > 0) ro.lead_ns = static_cast<Nanos>(o.delay_s * 1e9);
  ro.send_position = o.position_port != 0;
  ro.faults.drop_rate = o.drop;
  ro.faults.corrupt_rate = o.corrupt;
  ro.faults.truncate_rate = o.truncate;
  ro.faults.duplicate_rate = o.duplicate;
  ro.faults.reorder_rate = o.reorder;
  ro.faults.stall_ns = static_cast<Nanos>(o.stall_ms * 1e6);
  ro.faults.stall_every_ns = static_cast<Nanos>(o.stall_every_s * 1e9);
  ro.faults.seed = o.seed;
  try {
    ro.faults.validate();
  } catch (const std::invalid_argument& e) {
    throw cli::UsageError(e.what());
  }

  std::vector<Endpoint> dests{data};
  if (o.position_port != 0) dests.push_back(Endpoint{data.host, static_cast<std::uint16_t>(o.position_port)});
  if (!o.write_metadata.empty()) write_metadata(o, data.port);
  // SCHED_FIFO before the stream is made: from the clock's reading on, the first packet's deadline runs.
  apply_rt_priority(o.rt_priority);
  std::unique_ptr<mock::TruthStream> truth_stream;
  std::unique_ptr<mock::PacketStream> plain = make_stream(o, data.port, ro, truth_stream);
  mock::PacketStream& stream = truth_stream ? static_cast<mock::PacketStream&>(*truth_stream) : *plain;
  UdpSender sender(dests, o.send_buffer);

  const std::string what = !o.synthetic.empty() ? "synthetic " + o.synthetic : !o.pcap.empty() ? o.pcap : o.mcap + " " + o.mcap_topic;
  log::info("replay", what + " -> " + o.to +
                          (o.position_port ? " (position packets -> port " + std::to_string(o.position_port) + ")"
                                           : std::string(" (position packets skipped)")));
  const mock::ReplayStats st = mock::run_replay(stream, sender, ro);
  if (truth_stream) truth_stream->finish();
  std::fprintf(stderr, "%s\n", mock::summary_line(st).c_str());
  if (o.json) std::printf("%s\n", json_line(st).c_str());
  if (!st.stream_error.empty()) {
    std::fprintf(stderr, "error: %s ended early: %s\n", o.mcap.empty() ? "capture" : "recording", st.stream_error.c_str());
    return cli::kRuntime;
  }
  if (st.read == 0 && !st.stopped) {
    std::fprintf(stderr, "error: no UDP packets in %s\n", (o.mcap.empty() ? o.pcap : o.mcap + " " + o.mcap_topic).c_str());
    return cli::kRuntime;
  }
  return cli::kOk;
}

}  // namespace

void register_replay_command(CLI::App& lidar, cli::Context& ctx, mock::RecordingOpener open_recording) {
  auto opts = std::make_shared<ReplayCliOptions>();
  opts->open_recording = std::move(open_recording);
  auto* cmd = lidar.add_subcommand("replay", "mock LIDAR: send a capture or a synthetic sensor over UDP at real timing");
  auto* pcap = cmd->add_option("--pcap", opts->pcap, "capture to replay (pcap/pcapng)")->check(CLI::ExistingFile);
  auto* synth = cmd->add_option("--synthetic", opts->synthetic,
                                "render a synthetic sensor instead: " + mock::synthetic_model_names());
  pcap->excludes(synth);
  auto* mcap = cmd->add_option("--mcap", opts->mcap,
                               "a recording's raw LIDAR channel (rig record --raw) to replay: its file, or the folder "
                               "of a split recording (--split-*: its files in metadata.yaml's order, as one stream)")
                   ->check(CLI::ExistingPath);
  mcap->excludes(pcap)->excludes(synth);
  cmd->add_option("--mcap-topic", opts->mcap_topic, "with --mcap: the raw channel, /sensors/lidar/NAME/packets");
  cmd->add_option("--delay", opts->delay_s, "send the first packet S seconds after the start (a replayed drive: "
                  "time for the driver's subscribers to match)")->check(CLI::Range(0.0, 60.0));
  cmd->add_option("--to", opts->to, "destination HOST:PORT of the data packets (required unless only --write-metadata)");
  cmd->add_option("--rate", opts->rate, "speed factor (2 = twice as fast as recorded)")->capture_default_str();
  cmd->add_flag("--loop", opts->loop, "restart the capture (or recording) at its end");
  cmd->add_option("--rpm", opts->rpm, "synthetic: rotation speed")->capture_default_str()->check(CLI::Range(60.0, 1200.0));
  cmd->add_option("--phase-lock", opts->phase_lock,
                  "synthetic: the rotor passes DEG (the azimuth; Ouster: measurement id x 360 / W) at every whole "
                  "second, as a phase-locked sensor does; LIDARs locked alike complete their scans together")
      ->check(CLI::Range(0.0, 359.999));
  cmd->add_option("--return", "synthetic: strongest, last or dual (default strongest)")
      ->check(CLI::IsMember({"strongest", "last", "dual"}))
      ->each([o = opts.get()](const std::string& w) { o->returns = *parse_return_selection(w); });
  cmd->add_option("--calibration", opts->calibration,
                  "synthetic Velodyne/Hesai: render with this calibration (ROS YAML, VeloView XML, Hesai CSV)")
      ->check(CLI::ExistingFile);
  auto* synthetic_ouster = "synthetic Ouster (OS-LEGACY, OS)";
  cmd->add_option("--metadata", opts->metadata, "render the sensor this metadata JSON describes (default: a nominal OS-1)")
      ->check(CLI::ExistingFile)
      ->group(synthetic_ouster);
  cmd->add_option("--write-metadata", opts->write_metadata,
                  "write the metadata JSON the sensor renders with (the driver needs it); alone: write and exit")
      ->group(synthetic_ouster);
  cmd->add_option("--beams", opts->beams, "nominal OS-1: beams (16, 32, 64, 128)")
      ->capture_default_str()
      ->check(CLI::IsMember({16, 32, 64, 128}))
      ->group(synthetic_ouster);
  cmd->add_option("--lidar-mode", opts->lidar_mode, "nominal OS-1: 512x10, 1024x10, 2048x10, 512x20, 1024x20, 4096x5 "
                  "(default 1024x10, or 1024x20 at --rpm 1200)")->group(synthetic_ouster);
  cmd->add_option("--profile", opts->profile, "nominal OS: UDP profile (default RNG19_RFL8_SIG16_NIR16)")
      ->group(synthetic_ouster);
  cmd->add_option("--position-port", opts->position_port, "send position packets to this port on the same host")
      ->check(CLI::Range(0, 65535));
  cmd->add_option("--duration", opts->duration_s, "stop after S seconds (default: end of capture / Ctrl-C)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--count", opts->count, "stop after N packets read");
  auto* faults = "faults";
  cmd->add_option("--drop-rate", opts->drop, "probability a packet is dropped")->group(faults);
  cmd->add_option("--corrupt-rate", opts->corrupt, "probability 1-4 bytes of a packet are flipped")->group(faults);
  cmd->add_option("--truncate-rate", opts->truncate, "probability a packet is cut short")->group(faults);
  cmd->add_option("--duplicate-rate", opts->duplicate, "probability a packet is sent twice")->group(faults);
  cmd->add_option("--reorder-rate", opts->reorder, "probability a packet is swapped with the next")->group(faults);
  cmd->add_option("--stall-ms", opts->stall_ms, "insert a gap of MS milliseconds ...")->group(faults);
  cmd->add_option("--stall-every", opts->stall_every_s, "... every S seconds of stream time")->group(faults);
  cmd->add_option("--device", opts->device, "this sensor's name in the rig (fault plans, truth record, topic)")
      ->capture_default_str()
      ->group(faults);
  cmd->add_option("--fault", opts->fault_specs,
                  "a fault of the vocabulary, KIND[:NAME=VALUE]...[@START_S][+DURATION_S][~EVERY_S] (lidar.*, "
                  "host.network_delay; times after the replay's start); repeatable")
      ->group(faults);
  cmd->add_option("--fault-plan", opts->fault_plan, "the faults of --device in this plan file (rig chaos; times after its epoch)")
      ->check(CLI::ExistingFile)
      ->group(faults);
  cmd->add_option("--truth", opts->truth, "write the truth record (JSON Lines: scans, packets and their fates, faults)")
      ->group(faults);
  cmd->add_option("--seed", opts->seed, "random seed of the faults")->group(faults)->capture_default_str();
  cmd->add_option("--send-buffer", opts->send_buffer, "socket send buffer in bytes")->capture_default_str();
  cmd->add_option("--rt-priority", opts->rt_priority, "SCHED_FIFO priority for steady timing, 0 = normal scheduling")
      ->capture_default_str()
      ->check(CLI::Range(0, 99));
  cmd->add_flag("--json", opts->json, "print the summary as one JSON line on stdout");
  cmd->callback([opts, &ctx] { ctx.exit_code = run_replay_command(*opts); });
}

}  // namespace sensor_rig::lidar
