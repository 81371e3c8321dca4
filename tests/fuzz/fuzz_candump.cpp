// libFuzzer harness for candump -L lines: parse, and a parsed frame formats and parses back equal.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "sensor_rig/dbw/can/candump.hpp"

namespace can = sensor_rig::dbw::can;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view line(reinterpret_cast<const char*>(data), size);
  can::LogRecord r;
  if (can::parse_candump_line(line, r) != can::LineStatus::kOk) return 0;
  if (r.frame.len > (r.frame.fd ? 64 : 8)) std::abort();
  can::Frame back;
  if (!can::parse_frame(can::format_frame(r.frame), back) || !(back == r.frame)) std::abort();
  return 0;
}
