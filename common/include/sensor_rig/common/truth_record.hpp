#pragma once
// Truth records: what a mock device really did, written as it does it, so that `rig chaos` can hold
// the rig's output against it (docs/faults.md "Truth records"). One format for every mock: JSON Lines,
// a header line, then one line per unit the device produced (a scan, a frame, a CAN frame), per part
// it sent or did not (a packet, with its fate) and per fault it injected.
//
//   {"truth":1,"device":"front","class":"lidar","model":"VLP-32C","topic":"/sensors/lidar/front/points",
//    "unit":"scan","clock":"..."}
//   {"u":12,"acq":T,"dev":T,"parts":K}                    unit 12: true acquisition (vehicle ns), device
//                                                         clock reading, parts it was made of
//   {"p":SEQ,"u":12,"acq":T,"dev":T,"tx":T,"fate":"sent"[,"fault":ID][,"u2":13]}   one part and what became
//                                                         of it (u2: the last unit it has data in, when several)
//   {"f":ID,"kind":"lidar.reorder","at":T,"until":T,"u":12,"detail":"..."}  one fault occurrence
//
// Times are vehicle time (CLOCK_REALTIME ns) except "dev", the device's own clock as it stamps. Writing
// is buffered (one snprintf and a memcpy per line; BENCHMARKS.md "Truth records" measures it), and a
// line is whole or absent: a reader ignores a last line cut by a killed process and says so.
#include <cstdint>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::truth {

struct Header {
  std::string device;        // config name: front, stereo_left, paravan
  std::string device_class;  // lidar, camera, v4l2, dbw
  std::string model;         // VLP-32C, arv-fake, ...
  std::string topic;         // the ROS topic the rig publishes the units on ("" if none)
  std::string unit;          // scan, frame, can_frame
  std::string clock;         // what "dev" is: "sensor us since hour", "camera ns (PTP)", ...
};

// What became of a part (a packet, a frame's payload).
enum class Fate : std::uint8_t {
  kSent,        // on the wire as rendered
  kDropped,     // lost on the way (never on the wire)
  kCorrupted,   // on the wire with bytes changed
  kDuplicated,  // on the wire twice (a copy later)
  kDelayed,     // on the wire after later parts (reordered)
  kNotSent,     // the device did not produce it (blind sector, restart, dead): not a loss
  kTruncated,   // on the wire, cut short
};
std::string_view to_string(Fate f) noexcept;
bool parse_fate(std::string_view s, Fate& out) noexcept;
// The part reached the receiver with its bytes as rendered (possibly late or twice).
inline bool delivered_intact(Fate f) noexcept { return f == Fate::kSent || f == Fate::kDuplicated || f == Fate::kDelayed; }

struct UnitRecord {
  std::int64_t unit = 0;
  Nanos acq_ns = 0;  // true acquisition: a scan's first firing, a frame's exposure start (vehicle time)
  Nanos dev_ns = 0;  // the device clock's reading for it
  std::uint32_t parts = 0;  // parts the unit was made of (packets a complete scan has)
  Nanos exposure_ns = 0;    // a camera frame's exposure as the camera reported it in the frame ("exp"); 0: not reported
};

struct PartRecord {
  std::uint64_t seq = 0;  // per device, from 0, in rendering order
  std::int64_t unit = 0;
  Nanos acq_ns = 0;  // the part's own acquisition (a packet's first firing)
  Nanos dev_ns = 0;
  Nanos tx_ns = 0;   // handed to the socket (vehicle time); 0 when never sent
  Fate fate = Fate::kSent;
  std::uint64_t fault = 0;  // the fault occurrence that decided the fate, 0 = none
  std::int64_t unit_last = -1;  // a part with data in several units (a packet across a scan cut): the
                                // last of them ("u2"); -1 = only `unit`
};

struct FaultRecord {
  std::uint64_t id = 0;  // the plan's event id
  std::string kind;
  Nanos at_ns = 0;     // vehicle time the fault began
  Nanos until_ns = 0;  // ... and ended (= at_ns for a one-part fault)
  std::int64_t unit = -1;  // the unit it touched first, -1 = none
  std::string detail;
};

// A planned fault a mock did not inject says so: its line's detail begins with this, then why (a
// restarted mock's fault whose time fell while it was dead). It is in the record, not injected.
inline constexpr std::string_view kNotInjected = "not injected: ";
[[nodiscard]] inline bool injected(const FaultRecord& f) { return !f.detail.starts_with(kNotInjected); }

class Writer {
 public:
  // Appends (a restarted mock continues its device's record after a new header). Throws
  // std::runtime_error when the file cannot be created.
  Writer(const std::string& path, const Header& header);
  ~Writer();
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  void unit(const UnitRecord& r);
  void part(const PartRecord& r);
  void fault(const FaultRecord& r);
  // Puts the lines written so far on disk: the only call that does, short of a full buffer (64 KiB)
  // or the writer's end. Each mock calls it where its lines must be there (a frame, a send batch, a
  // fault), before the rig can have what they describe; a SIGKILL takes what is not flushed.
  void flush();
  [[nodiscard]] std::uint64_t lines() const noexcept { return lines_; }
  [[nodiscard]] const std::string& path() const noexcept { return path_; }

 private:
  void put(const char* line, int n);
  // The stream's buffer: lines between two flush()es go out in one write() up to this size.
  static constexpr std::size_t kBufferBytes = std::size_t{1} << 16;
  std::string path_;
  std::unique_ptr<char[]> buffer_;  // outlives file_: closed in ~Writer before the members go
  std::FILE* file_ = nullptr;
  std::mutex mutex_;
  std::uint64_t lines_ = 0;
};

// Opens a writer when `path` is not empty (the mocks' --truth FILE), else nullptr: one branch per
// record where the mock has nothing to write.
std::unique_ptr<Writer> open_if(const std::string& path, const Header& header);

struct Log {
  Header header;
  std::vector<UnitRecord> units;
  std::vector<PartRecord> parts;
  std::vector<FaultRecord> faults;
  bool cut_last_line = false;  // the writer was killed mid-line (the line is left out)
  int cut_lines = 0;           // such lines: at the end, or before a restarted writer's header
  int restarts = 0;            // headers after the first: the mock was restarted (unit ids of each run
                               // are offset by 2^40 per restart, so they never collide)
};

// Throws std::runtime_error naming file:line for anything but a cut last line.
Log read(const std::string& path);

}  // namespace sensor_rig::truth
