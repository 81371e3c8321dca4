#pragma once
// The mock LIDAR's truth record (common/truth_record.hpp, docs/faults.md): a packet stream that
// tags every data packet as a part, and, told by run_replay what became of each (ReplayObserver),
// writes one part line per packet once its fate and send time are known, one unit line per scan as
// the sensor closes it (unit_tracker.hpp) and one fault line per fault occurrence when it first
// acts (or at the end, unit -1, if it never did; flushed at once, so that a run killed after a
// fault acted leaves its line for the run restarted after it: FaultNote::before_start). A synthetic
// sensor goes through its own faults (sensor_faults.hpp); a capture's packets are parts of unit -1
// (the replay knows no scans).
#include <cstdint>
#include <future>
#include <memory>
#include <optional>
#include <set>
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
  // A campaign plan's fault whose time came before this run of the mock began (restarted after
  // host.kill_mock, or started late). Its line is an earlier run's when one wrote it (the record is
  // appended to: one line per fault across runs); else this run writes it: at once, unit -1, "not
  // injected", when it is over (`resumed` false: a one-packet fault, or its time span ended), or
  // when it first acts, when it is still on (`resumed`: this run injects what is left of it).
  bool before_start = false;
  bool resumed = false;
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
  // The batch's part lines on disk: a host.kill_mock right after it kept the scan it cut short
  // from the truth (its lines were in the writer's stdio buffer, ~40 of them), and the rig's count of that scan
  // as lost was judged phantom (rig chaos seed 3, OS-LEGACY: "counted 6 lost, 5 not published").
  void batch_sent() override;
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
  // A run that has before_start faults reads which of them earlier runs recorded, beside its sends
  // (a long record takes tens of ms), and settles them when that is in (or waits, `wait`).
  void read_earlier_runs();
  void settle_earlier_runs(bool wait);
  void put(Pending& p);
  Pending* pending(std::int64_t tag) noexcept;

  std::unique_ptr<FaultySensor> sensor_;
  std::unique_ptr<PacketStream> capture_;
  std::unique_ptr<truth::Writer> writer_;
  std::vector<FaultNote> faults_;
  std::vector<bool> noted_;
  std::future<std::set<std::uint64_t>> earlier_;  // fault ids earlier runs of the record wrote
  std::vector<Pending> ring_;  // parts in flight, by tag modulo its size
  std::uint64_t next_seq_ = 0;
  bool finished_ = false;
};

}  // namespace sensor_rig::lidar::mock
