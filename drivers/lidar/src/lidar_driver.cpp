#include "sensor_rig/drivers/lidar/lidar_driver.hpp"

#include <pthread.h>
#include <sched.h>

#include <cstring>

#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/lidar/udp_source.hpp"
#include "sensor_rig/lidar/scan_decoder.hpp"
#include "sensor_rig/lidar/velodyne/position_packet.hpp"
#include "sensor_rig/drivers/lidar/lidar_stamping.hpp"
#include "sensor_rig/dds/stamps_writer.hpp"

namespace sensor_rig::drivers {
namespace vel = lidar::velodyne;

namespace {

std::unique_ptr<lidar::ScanDecoder> make_driver_decoder(const LidarConfig& c) {
  try {
    return lidar::make_decoder(decoder_options(c));
  } catch (const lidar::DecoderConfigError& e) {
    throw std::runtime_error("lidar " + c.name + ": " + e.what());
  }
}

timesync::StamperConfig lidar_stamper_config(const LidarConfig& c, Nanos packet_span_ns) {
  return stamper_config(c.time_source, c.hour_source, c.clock_correction, packet_span_ns);
}

}  // namespace

struct LidarDriver::Impl {
  LidarConfig cfg;
  std::string topic_name;
  std::unique_ptr<lidar::ScanDecoder> decoder;
  bool velodyne = false;               // position packets and top-of-hour time are Velodyne's
  lidar::UdpSource data;
  std::unique_ptr<lidar::UdpSource> position;
  // 64 kB slots: the largest UDP payload (an OS-128 packet is ~25 kB; Velodyne 1206 B).
  lidar::SlotArena arena{64, 65536};
  lidar::SlotArena position_arena{4, 1024};
  dds::Topic<msg::PointCloud2> topic;
  dds::Writer<msg::PointCloud2> writer;
  dds::StampsWriter& stamps;
  timesync::PacketStamper stamper;  // one policy with `rig lidar decode` (timesync/packet_stamper.hpp)
  std::vector<msg::PointField> fields;
  std::thread thread;
  std::atomic<bool> stop_flag{false};

  // Counters shared with status(); written by the driver thread only.
  mutable std::mutex mutex;
  std::uint64_t scans = 0;
  std::uint64_t write_errors = 0;
  std::uint64_t position_packets = 0;
  PpsState pps = PpsState::kAbsent;
  bool have_position = false;
  std::optional<Nanos> gprmc_utc_ns;  // latest valid $GPRMC time
  Nanos last_scan_host_ns = 0;
  double scan_rate_hz = 0.0;
  std::size_t last_points = 0;
  std::uint32_t last_missing = 0;      // missing packets of the last published scan
  std::uint64_t incomplete_scans = 0;  // published scans with missing packets
  std::string last_error;
  lidar::DecoderCounters decoder_stats;
  lidar::UdpSourceStats udp_stats;
  timesync::StamperStatus sync;
  timesync::ClockMapperStatus absolute_sync;
  timesync::AbsoluteSource absolute_source = timesync::AbsoluteSource::kNone;

  Impl(const LidarConfig& c, const dds::Participant& p, dds::StampsWriter& s)
      : cfg(c),
        topic_name("/sensors/lidar/" + c.name + "/points"),
        decoder(make_driver_decoder(c)),
        velodyne(lidar::find_model(c.model) != nullptr && lidar::find_model(c.model)->vendor == "velodyne"),
        // No SO_REUSEADDR: a second driver on the same port must fail, not silently share packets.
        data(lidar::UdpSourceConfig{{c.host, static_cast<std::uint16_t>(c.port)}, c.receive_buffer_bytes, 64, false}),
        topic(p, topic_name, c.qos),
        writer(p, topic, c.qos),
        stamps(s),
        stamper(lidar_stamper_config(c, decoder->packet_span_ns())) {
    if (c.position_port != 0)
      position = std::make_unique<lidar::UdpSource>(lidar::UdpSourceConfig{
          {c.host, static_cast<std::uint16_t>(c.position_port)}, 1 << 20, 4, false});
    fields = msg::point_fields(lidar::kPointFields);
  }

  // Vehicle time of the packet's first firing (timesync/ decides how; see its README).
  Nanos packet_stamp(std::span<const std::byte> bytes, Nanos rx_ns) {
    timesync::DevicePacket p = device_packet(decoder->packet_time(bytes), rx_ns);
    p.gprmc_utc_ns = gprmc_utc_ns;
    p.pps = have_position ? pps : PpsState::kUnknown;
    return stamper.stamp(p);
  }

  void handle_position() {
    if (!position || !velodyne) return;
    const auto r = position->receive(position_arena.slots(), 0);
    for (std::size_t i = 0; i < r.count; ++i) {
      vel::PositionPacket pp;
      if (vel::parse_position_packet(position_arena.slots()[i].bytes(), pp) != lidar::PacketStatus::kOk) continue;
      std::lock_guard lock(mutex);
      ++position_packets;
      have_position = true;
      pps = pp.pps;
      if (pp.nmea == vel::NmeaStatus::kOk && pp.fix.valid) gprmc_utc_ns = pp.fix.utc_ns;
    }
  }

  void publish(lidar::Scan& scan) {
    const Nanos ready = vehicle_now_ns();
    msg::PointCloud2 pc{};
    pc.header.stamp = msg::to_time(scan.stamp);
    pc.header.frame_id = const_cast<char*>(cfg.frame_id.c_str());
    pc.height = 1;
    pc.width = static_cast<std::uint32_t>(scan.points.size());
    pc.fields._buffer = fields.data();
    pc.fields._length = pc.fields._maximum = static_cast<std::uint32_t>(fields.size());
    pc.is_bigendian = false;
    pc.point_step = sizeof(lidar::PointXYZIRT);
    pc.row_step = pc.point_step * pc.width;
    // The decoder's buffer is the published buffer: no copy between decoding and the writer.
    pc.data._buffer = reinterpret_cast<std::uint8_t*>(scan.points.data());
    pc.data._length = pc.data._maximum = pc.row_step;
    pc.is_dense = true;
    const Nanos publish = vehicle_now_ns();
    const auto rc = writer.write(pc, publish);
    const Nanos written = vehicle_now_ns();
    dds::SampleStamps st{scan.stamp, scan.first_rx_ns, scan.last_rx_ns, ready,        publish,
                    written,    scan.packets,     scan.dropped,     pc.row_step,  scan.missing_packets};
    stamps.write(topic_name, pc.header.stamp, pc.header.frame_id, scan.seq, st);
    std::lock_guard lock(mutex);
    if (!rc.ok()) {
      ++write_errors;
      last_error = "dds write: " + rc.message();
    }
    ++scans;
    last_points = scan.points.size();
    last_missing = scan.missing_packets;
    if (scan.missing_packets > 0) ++incomplete_scans;
    if (last_scan_host_ns != 0) {
      const double dt = static_cast<double>(publish - last_scan_host_ns) * 1e-9;
      if (dt > 0) scan_rate_hz = scan_rate_hz == 0.0 ? 1.0 / dt : 0.8 * scan_rate_hz + 0.2 / dt;
    }
    last_scan_host_ns = publish;
  }

  void run() {
    auto slots = arena.slots();
    while (!stop_flag.load() && !shutdown_requested()) {
      const auto r = data.receive(slots, 50);
      if (r.status == lidar::RecvStatus::kError) {
        std::lock_guard lock(mutex);
        last_error = std::string("receive: ") + std::strerror(r.error);
      }
      for (std::size_t i = 0; i < r.count; ++i) {
        const auto& s = slots[i];
        const auto packet = lidar::view(s, static_cast<std::uint16_t>(cfg.port));
        if (!decoder->is_data_packet(packet)) continue;
        if (auto scan = decoder->push(packet, packet_stamp(s.bytes(), s.rx_ns))) {
          publish(*scan);
          // Cyclone has serialized the sample: the buffer can take the next scan (no page faults).
          decoder->recycle(std::move(scan->points));
        }
      }
      handle_position();
      std::lock_guard lock(mutex);
      decoder_stats = decoder->counters();
      udp_stats = data.stats();
      sync = stamper.hour_status(vehicle_now_ns());
      absolute_sync = stamper.absolute_status(vehicle_now_ns());
      absolute_source = stamper.absolute_source();
    }
  }
};

LidarDriver::LidarDriver(const LidarConfig& cfg, const dds::Participant& participant, dds::StampsWriter& stamps)
    : impl_(std::make_unique<Impl>(cfg, participant, stamps)) {}

LidarDriver::~LidarDriver() { stop(); }

void LidarDriver::start() {
  impl_->thread = std::thread([this] { impl_->run(); });
  if (const int prio = impl_->cfg.realtime_priority; prio > 0) {
    // A driver thread that wakes late adds its delay to every scan: run it real-time when allowed.
    sched_param sp{};
    sp.sched_priority = prio;
    if (const int rc = pthread_setschedparam(impl_->thread.native_handle(), SCHED_FIFO, &sp); rc != 0)
      log::warn("lidar", impl_->cfg.name + ": SCHED_FIFO " + std::to_string(prio) + " refused (" + std::strerror(rc) +
                             "), running with normal priority");
  }
  log::info("lidar", impl_->cfg.name + ": " + impl_->cfg.model + " on udp " + impl_->cfg.host + ":" +
                         std::to_string(impl_->data.port()) + " -> " + impl_->topic_name);
}

void LidarDriver::stop() {
  impl_->stop_flag.store(true);
  if (!impl_->thread.joinable()) return;
  impl_->thread.join();
  // One summary line per driver: what arrived, what was published, what was dropped and why.
  const auto st = status();
  std::string line = impl_->cfg.name + ":";
  for (const auto& [k, v] : st.values)
    if (k == "scans" || k == "packets" || k.rfind("dropped", 0) == 0 || k == "packets_dropped" || k == "kernel_drops" || k == "missing_packets" || k == "time_jumps" ||
        k == "stamp_source" || k == "sync")
      line += " " + k + "=" + v;
  log::info("lidar", line);
}

std::string LidarDriver::topic() const { return impl_->topic_name; }

dds::DriverStatus LidarDriver::status() const {
  const auto& c = impl_->cfg;
  std::lock_guard lock(impl_->mutex);
  dds::DriverStatus s;
  s.name = "lidar/" + c.name;
  s.hardware_id = c.model + "@" + c.host + ":" + std::to_string(c.port);
  const Nanos age = impl_->last_scan_host_ns == 0 ? -1 : vehicle_now_ns() - impl_->last_scan_host_ns;
  if (impl_->scans == 0) {
    s.level = dds::Level::kWarn;
    s.message = "waiting for packets";
  } else if (age > 1'000'000'000) {
    s.level = dds::Level::kError;
    s.message = "no scan for " + std::to_string(age / 1'000'000) + " ms (device dead?)";
  } else if (!impl_->last_error.empty()) {
    s.level = dds::Level::kWarn;
    s.message = impl_->last_error;
  } else if (impl_->last_missing > 0) {
    s.level = dds::Level::kWarn;
    s.message = "last scan incomplete: " + std::to_string(impl_->last_missing) + " packets missing";
  } else {
    s.message = "running";
  }
  const auto& d = impl_->decoder_stats;
  const auto& u = impl_->udp_stats;
  s.add("topic", impl_->topic_name);
  s.add_number("scans", impl_->scans);
  s.add("scan_rate_hz", std::to_string(impl_->scan_rate_hz));
  s.add_number("points_last_scan", impl_->last_points);
  s.add_number("packets", d.packets);
  s.add_number("packets_dropped", d.dropped());
  for (std::size_t i = 1; i < d.by_status.size(); ++i)
    if (d.by_status[i] != 0)
      s.add_number(std::string("dropped_") + lidar::to_string(static_cast<lidar::PacketStatus>(i)), d.by_status[i]);
  s.add_number("missing_packets_last_scan", impl_->last_missing);
  s.add_number("missing_packets", d.missing_packets);
  s.add_number("incomplete_scans", impl_->incomplete_scans);
  s.add_number("implausible_steps", d.implausible_steps);
  s.add_number("time_jumps", d.time_jumps);
  s.add_number("kernel_drops", u.kernel_drops);
  s.add_number("truncated", u.truncated);
  s.add_number("write_errors", impl_->write_errors);
  s.add("time_source", timesync::to_string(c.time_source));
  s.add_number("position_packets", impl_->position_packets);
  s.add("pps", impl_->have_position ? to_string(impl_->pps) : "no position packets");
  s.add("gprmc", impl_->gprmc_utc_ns ? "valid" : "absent");
  const auto& t = impl_->sync;
  if (c.time_source == timesync::TimeSource::kHost) {
    s.add("stamp_source", "host");
  } else if (impl_->velodyne) {
    s.add("stamp_source", timesync::to_string(t.last_source));
    s.add("hour_source", timesync::to_string(t.hour_source));
    s.add("sync", timesync::to_string(t.sync));
    s.add_number("sync_offset_ns", t.mapper.offset_ns);
    s.add("sync_drift_ppm", std::to_string(t.mapper.drift_ppm));
    s.add_number("sync_residual_p99_ns", t.mapper.residual_p99_ns);
    s.add_number("sync_jumps", t.mapper.jumps);
    s.add_number("bad_timestamps", t.bad_timestamps);
    s.add_number("host_fallbacks", t.host_fallbacks);
  } else {
    const auto& m = impl_->absolute_sync;
    s.add("stamp_source", timesync::to_string(impl_->absolute_source));
    s.add("sync", timesync::to_string(m.state));
    s.add_number("sync_offset_ns", m.offset_ns);
    s.add("sync_drift_ppm", std::to_string(m.drift_ppm));
    s.add_number("sync_residual_p99_ns", m.residual_p99_ns);
    s.add_number("sync_jumps", m.jumps);
  }
  return s;
}

}  // namespace sensor_rig::drivers
