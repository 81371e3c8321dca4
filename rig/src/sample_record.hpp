#pragma once
// One sample of one topic as `rig monitor` saw it: the driver's source stamps (rt/rig/stamps) joined
// with the monitor's receive time. The unit of `--record` (CSV) and of the latency plot.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/unique_fd.hpp"

namespace sensor_rig::rig {

// Latency stages (rig/README.md "Monitor stages"); the order of the table, JSON and plot.
// ecu: drive-by-wire commands only, CAN frames written -> the first ECU status frame received after.
inline constexpr std::array<const char*, 8> kStageNames = {"sensor", "assemble", "process", "write",
                                                           "dds",    "total",    "to_wire", "ecu"};
enum Stage : std::size_t { kSensor, kAssemble, kProcess, kWrite, kDds, kTotal, kToWire, kEcu };
inline constexpr std::size_t kStageCount = kStageNames.size();

// Times are vehicle ns; 0 = not known (the driver has no such stamp, or the sample was lost).
struct SampleRecord {
  std::string topic;  // ROS name
  std::uint64_t seq = 0;
  Nanos acquisition_ns = 0;  // sensor: first firing / exposure start
  Nanos first_rx_ns = 0;     // first packet received
  Nanos last_rx_ns = 0;      // complete: last packet received
  Nanos publish_ns = 0;      // DDS write called (the sample's source timestamp)
  Nanos written_ns = 0;      // DDS write returned
  Nanos received_ns = 0;     // the monitor received it; 0 = lost
  Nanos ecu_status_ns = 0;   // dbw commands: first ECU status frame received after written_ns; 0 = none
  std::uint32_t missing_packets = 0;
  std::uint32_t dropped = 0;
  std::uint32_t size_bytes = 0;
  std::uint32_t packets = 0;  // packets that made the sample (rig chaos holds it against the truth)

  [[nodiscard]] bool lost() const { return received_ns == 0; }
  // When the rig had it out, on the host's clock, as its /diagnostics reports are stamped: what a
  // flag ("stamp_sync: unsynchronized") is held against. Not the stamp: a stamp slewed after a host
  // clock step lies up to the step after its publication (330 ms: a clock-step campaign's camera
  // frames, published inside a flagged span, stamped in the 120 ms between two).
  [[nodiscard]] Nanos out_ns() const { return publish_ns != 0 ? publish_ns : written_ns != 0 ? written_ns : acquisition_ns; }
};

// Each stage's latency in ms, where both its stamps are known.
std::array<std::optional<double>, kStageCount> stage_latencies_ms(const SampleRecord& r);

// CSV: the header line (without newline), one line per record (with newline), and the reverse.
// Unknown times are empty fields.
std::string_view record_csv_header();
std::string to_csv_line(const SampleRecord& r);
std::optional<SampleRecord> parse_csv_line(std::string_view line);
// The same for a recording with `fields` columns: 13, 12 (before `packets`) or 11 (before `ecu_status_ns`).
std::optional<SampleRecord> parse_csv_line(std::string_view line, std::size_t fields);

// A CSV file that only ever holds whole lines: lines are collected and written with one write(2)
// per flush(), so a monitor killed at any moment leaves a valid file up to the last line.
class RecordFile {
 public:
  explicit RecordFile(const std::string& path);  // truncates and writes the header; throws on error
  void add(const SampleRecord& r) { pending_ += to_csv_line(r); }
  void flush();  // throws std::runtime_error when the disk refuses
  [[nodiscard]] std::uint64_t rows() const noexcept { return rows_; }

 private:
  UniqueFd fd_;
  std::string path_;
  std::string pending_;
  std::uint64_t rows_ = 0;
};

// Every record of a CSV file (header checked); throws std::runtime_error naming file:line.
std::vector<SampleRecord> read_records(const std::string& path);

}  // namespace sensor_rig::rig
