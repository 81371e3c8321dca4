// Faults of the LIDAR itself over a synthetic sensor (see sensor_faults.hpp).
#include "sensor_rig/lidar/mock/sensor_faults.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace sensor_rig::lidar::mock {
namespace {

bool in_sector(double deg, double from, double to) noexcept {
  return from <= to ? (deg >= from && deg < to) : (deg >= from || deg < to);
}

}  // namespace

FaultySensor::FaultySensor(SensorFactory make, const SensorSetup& setup, std::vector<SensorFault> faults,
                           std::unique_ptr<SyntheticSensor> first)
    : make_(std::move(make)),
      setup_(setup),
      faults_(std::move(faults)),
      sensor_(first ? std::move(first) : make_(setup)),
      fields_(*sensor_),
      tracker_(sensor_->unit_rule()),
      rpm_now_(setup.rpm) {
  const bool ouster = sensor_->unit_rule().kind == UnitRule::Kind::kFrame;
  for (const SensorFault& f : faults_) {
    if (f.kind != SensorFault::Kind::kRpmChange) continue;
    if (ouster)
      throw std::invalid_argument("lidar.rpm_change: an Ouster turns at its lidar mode's rate (a mode change is a reconfiguration)");
    SensorSetup s = setup_;
    s.rpm = f.rpm;
    (void)make_(s);  // throws what the model refuses (e.g. a Pandar40P at 300 rpm)
  }
}

const SensorFault* FaultySensor::active(SensorFault::Kind k, Nanos t) const noexcept {
  for (const SensorFault& f : faults_)
    if (f.kind == k && t >= f.from_ns && t < std::max(f.until_ns, f.from_ns + 1)) return &f;
  return nullptr;
}

void FaultySensor::note(const SensorFault& f, std::int64_t unit) {
  if (std::find(acted_.begin(), acted_.end(), f.id) != acted_.end()) return;
  acted_.push_back(f.id);
  began_.push_back(Began{f.id, unit});
}

std::unique_ptr<SyntheticSensor> FaultySensor::swap(const SyntheticPacket& at, double rpm, double rotor_deg,
                                                    std::uint32_t boot) {
  SensorSetup s = setup_;
  s.start_ns = at.time_ns;
  s.rpm = rpm;
  s.start_rotor_deg = rotor_deg;
  s.boot = boot;
  auto sensor = make_(s);
  // The packet cadence goes on: the new sensor's first packet is due when the replaced one was.
  sensor->set_start_ns(at.time_ns - sensor->first_packet_offset_ns());
  return sensor;
}

SyntheticPacket FaultySensor::pull() {
  SyntheticPacket p = sensor_->next();
  if (const SensorFault* r = active(SensorFault::Kind::kRestart, p.time_ns);
      r != nullptr && std::find(acted_.begin(), acted_.end(), r->id) == acted_.end()) {
    note(*r, -1);
    // Silent until the fault ends, then a new boot: rotor at 0°, counters and frame ids from 0.
    SensorSetup s = setup_;
    s.start_ns = r->until_ns;
    s.rpm = rpm_now_;
    s.boot = ++boot_;
    sensor_ = make_(s);
    tracker_.restart();
    second_.reset();
    pending_second_.reset();
    p = sensor_->next();
  }
  if (!p.truth.data) return p;
  const SensorFault* rpm = active(SensorFault::Kind::kRpmChange, p.time_ns);
  if (rpm != nullptr && rpm->id != rpm_fault_) {
    note(*rpm, -1);
    rpm_fault_ = rpm->id;
    rpm_now_ = rpm->rpm;
    sensor_ = swap(p, rpm_now_, p.truth.rotor_deg, boot_);
    p = sensor_->next();
  } else if (rpm == nullptr && rpm_fault_ != 0) {
    rpm_fault_ = 0;
    rpm_now_ = setup_.rpm;
    sensor_ = swap(p, rpm_now_, p.truth.rotor_deg, boot_);
    p = sensor_->next();
  }
  return p;
}

FaultyPacket FaultySensor::next() {
  if (!head_) {
    head_ = pull();
    const SyntheticPacket& p = *head_;
    if (const SensorFault* s2 = active(SensorFault::Kind::kSecondSensor, p.time_ns);
        s2 != nullptr && s2->id != second_fault_ && p.truth.data) {
      note(*s2, -1);
      second_fault_ = s2->id;
      second_until_ = s2->until_ns;
      SensorSetup s = setup_;
      s.start_ns = p.time_ns;
      s.rpm = rpm_now_;
      s.start_rotor_deg = std::fmod(p.truth.rotor_deg + 180.0, 360.0);
      s.boot = 1000 + static_cast<std::uint32_t>(s2->id);  // another unit: another Ouster init_id
      second_ = make_(s);
      second_->set_start_ns(p.time_ns + static_cast<Nanos>(1e9 / sensor_->packets_per_second() / 3.0) -
                            second_->first_packet_offset_ns());
      pending_second_.reset();
    }
  }
  // The second sensor's packet goes first when it is due first (the device's waits in head_).
  if (second_) {
    if (!pending_second_) pending_second_ = second_->next();
    if (pending_second_->time_ns >= second_until_) {
      second_.reset();
      pending_second_.reset();
    } else if (pending_second_->time_ns < head_->time_ns) {
      FaultyPacket o;
      o.packet = *pending_second_;
      o.device = false;
      pending_second_.reset();
      return o;
    }
  }
  const SyntheticPacket p = *head_;
  head_.reset();
  FaultyPacket out;
  out.packet = p;
  if (p.truth.data) {
    const Nanos t = p.truth.acq_ns;
    bool counted = true;
    const SensorFault* blind = active(SensorFault::Kind::kBlindSector, t);
    if (blind != nullptr && in_sector(p.truth.rotor_deg, blind->from_deg, blind->to_deg)) {
      out.fate = truth::Fate::kNotSent;
      out.fault = blind->id;
      out.packet.bytes = {};
      counted = false;
    } else if (const SensorFault* stuck = active(SensorFault::Kind::kStuckAzimuth, t)) {
      if (stuck->id != stuck_fault_) {
        stuck_fault_ = stuck->id;
        frozen_.assign(p.bytes.begin(), p.bytes.end());
      }
      own_.assign(p.bytes.begin(), p.bytes.end());
      fields_.freeze_azimuth(own_, frozen_);
      out.packet.bytes = own_;
      out.fate = truth::Fate::kCorrupted;
      out.fault = stuck->id;
    }
    out.units = tracker_.add(p.truth, counted);
    if (out.fault != 0) note(*std::find_if(faults_.begin(), faults_.end(), [&](const SensorFault& f) { return f.id == out.fault; }),
                             out.units.first);
  }
  return out;
}

}  // namespace sensor_rig::lidar::mock
