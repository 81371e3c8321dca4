#pragma once
// The mock LIDAR's truth record (common/truth_record.hpp, docs/faults.md): a packet stream that
// tags every data packet as a part, and, told by run_replay what became of each (ReplayObserver),
// writes one part line per packet once its fate and send time are known, one unit line per scan as
// the sensor closes it (unit_tracker.hpp) and one fault line per fault occurrence when it first
// acts (or at the end, unit -1, if it never did). A synthetic sensor goes through its own faults
// (sensor_faults.hpp); a capture's packets are parts of unit -1 (the replay knows no scans).
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sensor_rig/common/truth_record.hpp"
#include "sensor_rig/lidar/mock/replay.hpp"
#include "sensor_rig/lidar/mock/sensor_faults.hpp"

namespace sensor_rig::lidar::mock {

// A fault occurrence of this device, as its fault line says it (vehicle times).
struct FaultNote {
  std::uint64_t id = 0;
  std::string kind;
  Nanos at_ns = 0, until_ns = 0;
  std::string detail;
};

class TruthStream final : public PacketStream, public ReplayObserver {
 public:
  // `writer` may be null: the faults run, nothing is written.
  TruthStream(std::unique_ptr<FaultySensor> sensor, std::unique_ptr<truth::Writer> writer, std::vector<FaultNote> faults);
  TruthStream(std::unique_ptr<PacketStream> capture, std::unique_ptr<truth::Writer> writer, std::vector<FaultNote> faults);
  ~TruthStream() override;

  std::optional<StreamPacket> next() override;
  bool rewind() override;
  [[nodiscard]] std::string error() const override;
  void fate(std::int64_t tag, truth::Fate fate, std::uint64_t fault) override;
  void sent(std::int64_t tag, Nanos tx_ns) override;
  // Writes the parts still pending (never sent: tx 0, fate not_sent: the run ended first), the open units and the faults that never
  // acted, then flushes. Called by the destructor if not before.
  void finish();

 private:
  struct Pending {
    truth::PartRecord r;
    bool live = false;
  };
  void write_units();
  void note_fault(std::uint64_t id, std::int64_t unit);
  void put(Pending& p);
  Pending* pending(std::int64_t tag) noexcept;

  std::unique_ptr<FaultySensor> sensor_;
  std::unique_ptr<PacketStream> capture_;
  std::unique_ptr<truth::Writer> writer_;
  std::vector<FaultNote> faults_;
  std::vector<bool> noted_;
  std::vector<Pending> ring_;  // parts in flight, by tag modulo its size
  std::uint64_t next_seq_ = 0;
  bool finished_ = false;
};

}  // namespace sensor_rig::lidar::mock
