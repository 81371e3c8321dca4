#pragma once
// candump log + DBC -> one row per decoded signal value (`rig can decode`, SPEC §7):
//   t,iface,id,message,signal,value
// t as in the log, id in hex (3 digits standard, 8 extended), value with the signal's precision.
#include <cstdint>
#include <functional>
#include <istream>
#include <ostream>
#include <string>
#include <vector>

#include "sensor_rig/dbw/can/candump.hpp"
#include "sensor_rig/dbw/dbc/database.hpp"

namespace sensor_rig::dbw::can {

struct DecodeStats {
  std::uint64_t frames = 0;     // well-formed log lines
  std::uint64_t decoded = 0;    // frames matching a selected message
  std::uint64_t rows = 0;       // signal values written
  std::uint64_t unknown = 0;    // frames with no message in the DBC
  std::uint64_t short_frames = 0;  // frames shorter than a signal needs
  std::uint64_t malformed = 0;  // lines that are not candump -L
};

class LogDecoder {
 public:
  // `selection`: "MSG.SIG" or "MSG.*"/"MSG"; empty = every signal. Throws std::invalid_argument naming
  // an unknown message or signal.
  LogDecoder(const dbc::Database& db, const std::vector<std::string>& selection);

  struct Row {
    const LogRecord* record;
    const dbc::Message* message;
    const dbc::Signal* signal;
    double value;
  };
  // Calls `sink` for every selected signal value of the record (multiplexing honoured).
  void decode(const LogRecord& rec, const std::function<void(const Row&)>& sink, DecodeStats& stats) const;
  // Whole log to CSV with header.
  DecodeStats to_csv(std::istream& log, std::ostream& csv) const;

  static void write_header(std::ostream& csv);
  static void write_row(std::ostream& csv, const Row& row);

 private:
  struct Selected {
    const dbc::Message* message;
    std::vector<const dbc::Signal*> signals;
  };
  const dbc::Database& db_;
  std::vector<Selected> selected_;
  [[nodiscard]] const Selected* find(const Frame& f) const noexcept;
};

[[nodiscard]] std::string format_id(const Frame& f);

}  // namespace sensor_rig::dbw::can
