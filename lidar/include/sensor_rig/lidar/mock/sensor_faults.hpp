#pragma once
// What a LIDAR itself does wrong (the vocabulary's lidar.restart, stuck_azimuth, rpm_change,
// blind_sector, second_sensor), as a thin layer over a synthetic sensor: it switches sensors,
// rewrites azimuth fields or withholds packets at the fault's vehicle times, and says for every
// data packet what became of it and which scans (units) it belongs to. Network faults are not
// here (scheduled_faults.hpp). Pure: a sensor factory and times in, packets out; no clock, no I/O.
//
// - restart: silent from `from` to `until` (no packets at all), then a new boot: the rotor starts
//   at 0°, the packet counters at 0 (Hesai UDP sequence), Ouster frame ids at 0 and a new init_id;
//   the clock of these PTP/GPS-synced sensors is right again at once (time continues).
// - stuck_azimuth: every azimuth field (Ouster: measurement id, LEGACY encoder count) keeps the
//   value of the first packet in the fault: fate corrupted.
// - rpm_change: the rotor turns at `rpm` (packet rate unchanged, as the sensors do); Ouster is refused.
// - blind_sector: packets whose first firing is in [from_deg, to_deg) are not produced: not_sent.
// - second_sensor: another sensor of the same model, its rotor 180° away and its packets a third
//   of a packet period off, sends too (merged by time; its packets are not the device's units).
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/truth_record.hpp"
#include "sensor_rig/lidar/mock/packet_fields.hpp"
#include "sensor_rig/lidar/mock/synthetic_sensor.hpp"
#include "sensor_rig/lidar/mock/unit_tracker.hpp"

namespace sensor_rig::lidar::mock {

struct SensorFault {
  enum class Kind : std::uint8_t { kRestart, kStuckAzimuth, kRpmChange, kBlindSector, kSecondSensor };
  std::uint64_t id = 0;  // the plan's event id
  Kind kind = Kind::kRestart;
  Nanos from_ns = 0;     // vehicle time
  Nanos until_ns = 0;
  double rpm = 0.0;      // rpm_change
  double from_deg = 0.0, to_deg = 0.0;  // blind_sector, rotor degrees past the cut
};

// How to make the sensor again mid-run: same model and options, these changed.
struct SensorSetup {
  Nanos start_ns = 0;
  double rpm = 600.0;
  double start_rotor_deg = 0.0;
  std::uint32_t boot = 0;
};
using SensorFactory = std::function<std::unique_ptr<SyntheticSensor>(const SensorSetup&)>;

struct FaultyPacket {
  SyntheticPacket packet;  // bytes empty when not produced (not_sent)
  bool device = true;      // false: the second sensor's packet
  truth::Fate fate = truth::Fate::kSent;
  std::uint64_t fault = 0;
  UnitSpan units;          // the device's data packets
};

class FaultySensor {
 public:
  // `first`: the sensor as configured (its setup: `setup`), made by `make` when null (a sender
  // builds it before it reads the clock: building an Ouster's rays takes milliseconds, and its
  // first packet may be due 2 ms later). Throws std::invalid_argument when a fault cannot be done
  // by this model (e.g. an rpm it cannot turn at, rpm_change on an Ouster).
  FaultySensor(SensorFactory make, const SensorSetup& setup, std::vector<SensorFault> faults,
               std::unique_ptr<SyntheticSensor> first = nullptr);

  FaultyPacket next();
  [[nodiscard]] const SyntheticSensor& sensor() const noexcept { return *sensor_; }
  UnitTracker& units() noexcept { return tracker_; }
  // Faults that have begun acting, with the first unit they touched (once each, then cleared).
  struct Began {
    std::uint64_t id;
    std::int64_t unit;
  };
  std::vector<Began>& began() noexcept { return began_; }

 private:
  std::unique_ptr<SyntheticSensor> swap(const SyntheticPacket& at, double rpm, double rotor_deg, std::uint32_t boot);
  [[nodiscard]] const SensorFault* active(SensorFault::Kind k, Nanos t) const noexcept;
  void note(const SensorFault& f, std::int64_t unit);
  SyntheticPacket pull();  // the device's next packet, after restarts and rpm changes

  SensorFactory make_;
  SensorSetup setup_;
  std::vector<SensorFault> faults_;
  std::vector<std::uint64_t> acted_;
  std::unique_ptr<SyntheticSensor> sensor_, second_;
  PacketFields fields_;
  UnitTracker tracker_;
  double rpm_now_ = 0.0;
  std::uint64_t rpm_fault_ = 0;  // the rpm_change in force (0 = nominal)
  std::uint64_t second_fault_ = 0;
  std::uint32_t boot_ = 0;
  std::vector<std::byte> stuck_, frozen_, own_;
  std::uint64_t stuck_fault_ = 0;
  std::optional<SyntheticPacket> head_, pending_second_;
  Nanos second_until_ = 0;
  std::vector<Began> began_;
};

}  // namespace sensor_rig::lidar::mock
