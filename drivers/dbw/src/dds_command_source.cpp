// `rig dbw send`: a fixed command at a fixed rate on /vehicle/dbw/cmd; ends by simply stopping.
#include <time.h>

#include <ctime>
#include <stdexcept>
#include <string>

#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/drivers/dbw/dds_bridge.hpp"
#include "sensor_rig/drivers/dbw/dds_types.hpp"
#include "sensor_rig/drivers/dbw/dds_domain.hpp"

namespace sensor_rig::drivers {

using namespace sensor_rig::dbw;  // NOLINT(google-build-using-namespace): the node of the dbw area

namespace {
constexpr Nanos kEdgeHoldNs = 200'000'000;

// With DDS Security Cyclone refuses the writer when the identity's permissions do not grant
// publishing commands: say so in those words.
dds::Writer<msg::DbwCommand> make_writer(dds::Participant& p, dds::Topic<msg::DbwCommand>& t,
                                         const CommandSourceOptions& o) {
  try {
    return dds::Writer<msg::DbwCommand>(p, t);
  } catch (const dds::DdsError& e) {
    if (!e.not_allowed_by_security()) throw;
    throw std::runtime_error("identity '" + o.identity + "' may not publish " + kCmdTopic +
                             " (its permissions in " + o.security_dir + " do not grant it): " + e.what());
  }
}
}  // namespace

std::uint64_t run_command_source(const CommandSourceOptions& o) {
  const dds::SecurityConfig security = security_config(o.security_dir, o.identity);
  if (security.enabled()) {  // issue 28: say so before the identity lapses (the bridge reports it in /diagnostics)
    const auto e = dds::security_expiry(security);
    if (e.not_after - std::time(nullptr) < static_cast<std::time_t>(dds::kExpiryWarnDays) * 86400)
      log::warn("dbw", "send: the " + e.what + " of identity '" + o.identity + "' expires within " +
                           std::to_string(dds::kExpiryWarnDays) + " days");
  }
  dds::Participant participant(domain_config(o.domain), security);
  dds::Topic<msg::DbwCommand> topic(participant, kCmdTopic);
  const auto writer = make_writer(participant, topic, o);
  if (!writer.wait_for_readers(1, static_cast<int>(o.wait_for_reader_s * 1000)))
    log::warn("dbw", "send: no bridge matched within " + std::to_string(o.wait_for_reader_s) + " s; sending anyway");
  const Nanos period = static_cast<Nanos>(1e9 / o.rate_hz);
  const auto offset = static_cast<Nanos>(o.clock_offset_s * 1e9);  // this process's clock, as if off
  const Nanos start = monotonic_now_ns();
  const Nanos end = start + static_cast<Nanos>(o.duration_s * 1e9);
  msg::DbwCommand c{};
  char frame_id[] = "base_link";
  c.header.frame_id = frame_id;
  std::uint64_t sent = 0;
  for (Nanos next = start; next < end && !shutdown_requested(); next += period) {
    timespec ts{static_cast<time_t>(next / 1'000'000'000), static_cast<long>(next % 1'000'000'000)};
    ::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
    const Nanos stamp = vehicle_now_ns() + offset;
    c.header.stamp = msg::to_time(stamp);
    c.seq = ++sent;
    // The edge: enable=false for the first kEdgeHoldNs, not one sample. The writer having matched
    // the bridge does not mean the bridge has matched the writer yet (discovery runs both ways):
    // a volatile reader that matches late never sees the samples before, and a lost single
    // false sample would leave the bridge without an edge, never engaging.
    c.enable = o.enable && !(o.enable_edge && (sent == 1 || next - start < kEdgeHoldNs));
    c.steering_angle = o.steer;
    c.steering_torque = 0.0;
    c.throttle = o.throttle;
    c.brake = o.brake;
    c.accel = o.accel;
    c.gear = static_cast<std::uint8_t>(o.gear);
    writer.write(c, stamp);
  }
  return sent;
}

}  // namespace sensor_rig::drivers
