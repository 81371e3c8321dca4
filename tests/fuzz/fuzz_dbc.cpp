// libFuzzer harness for the DBC parser and signal codec (no I/O: text in, database out).
// Input: byte 0 selects a frame fill pattern; the rest is DBC text. Invariants: parse either succeeds
// or throws DbcError with a line inside the text; every parsed signal fits its message, decodes on a
// frame of the message's size, and an encoded value reads back within half a step (or clamps).
// Seed corpus: config/dbw/paravan_ref.dbc and ../shared/data/can/**/*.dbc (copy, do not commit them).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>
#include <vector>

#include "sensor_rig/dbw/dbc/codec.hpp"
#include "sensor_rig/dbw/dbc/parser.hpp"

namespace dbc = sensor_rig::dbw::dbc;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t fill = data[0];
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  dbc::Database db;
  try {
    db = dbc::parse(text, "fuzz.dbc");
  } catch (const dbc::DbcError& e) {
    int lines = 1;
    for (char c : text) lines += c == '\n' ? 1 : 0;
    if (e.line < 0 || e.line > lines) std::abort();
    return 0;
  }
  std::vector<std::uint8_t> frame(64);
  for (std::size_t i = 0; i < frame.size(); ++i) frame[i] = static_cast<std::uint8_t>(fill * (i + 1));
  for (const auto& m : db.messages) {
    for (const auto& s : m.signals) {
      if (!dbc::signal_fits(s, m.size)) std::abort();
      const std::span<std::uint8_t> payload(frame.data(), m.size);
      const auto v = dbc::decode(s, payload);
      if (!v) std::abort();
      (void)dbc::format_value(s, *v);
      (void)dbc::signal_active(m, s, payload);
      if (s.value_type != dbc::ValueType::kInteger || !std::isfinite(*v)) continue;
      const auto st = dbc::encode(s, *v, payload);
      if (st == dbc::EncodeStatus::kOutOfFrame) std::abort();
    }
  }
  return 0;
}
