#pragma once
// The can-utils `candump -L` log format, one frame per line:
//   (1436509052.249713) can0 123#DEADBEEF        classic, 3 hex digits = standard id
//   (1436509052.249713) can0 12345678#00         8 hex digits = extended id
//   (1436509052.249713) can0 123#R               remote request (optionally R<len>)
//   (1436509052.249713) can0 123##1DEADBEEF      CAN FD, first nibble = flags (1 BRS, 2 ESI)
//   (1436509052.249713) can0 20000080#000...     error frame (CAN_ERR_FLAG in the id)
// Pure text <-> Frame; the reader counts what it could not parse instead of stopping.
#include <cstdint>
#include <istream>
#include <string>
#include <string_view>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/dbw/can/frame.hpp"

namespace sensor_rig::dbw::can {

struct LogRecord {
  Nanos stamp = 0;         // from the "(sec.frac)" field
  std::string stamp_text;  // exactly as written, without parentheses
  std::string iface;
  Frame frame;
};

enum class LineStatus : std::uint8_t { kOk, kBlank, kMalformed };
LineStatus parse_candump_line(std::string_view line, LogRecord& out);
[[nodiscard]] std::string format_candump_line(Nanos stamp, std::string_view iface, const Frame& f);
// "123#DEADBEEF" part only.
[[nodiscard]] std::string format_frame(const Frame& f);
bool parse_frame(std::string_view text, Frame& out);

class CandumpReader {
 public:
  explicit CandumpReader(std::istream& in) : in_(in) {}
  // Next well-formed record; false at end of input. Malformed lines are counted and skipped.
  bool next(LogRecord& out);
  [[nodiscard]] std::uint64_t malformed() const noexcept { return malformed_; }
  [[nodiscard]] std::uint64_t line() const noexcept { return line_; }
  [[nodiscard]] std::uint64_t first_bad_line() const noexcept { return first_bad_line_; }

 private:
  std::istream& in_;
  std::string buf_;
  std::uint64_t line_ = 0;
  std::uint64_t malformed_ = 0;
  std::uint64_t first_bad_line_ = 0;
};

}  // namespace sensor_rig::dbw::can
