#pragma once
// DBC text -> Database. Throws DbcError naming "source:line: message" for anything it cannot
// take: unknown keywords, malformed entries, signals outside their message, duplicate ids.
#include <stdexcept>
#include <string>
#include <string_view>

#include "sensor_rig/dbw/dbc/database.hpp"

namespace sensor_rig::dbw::dbc {

struct DbcError : std::runtime_error {
  DbcError(std::string source, int line, const std::string& message);
  std::string source;
  int line;
};

[[nodiscard]] Database parse(std::string_view text, std::string_view source_name = "<dbc>");
[[nodiscard]] Database load_file(const std::string& path);
// Several files into one database (later files add messages; a clashing id is an error).
[[nodiscard]] Database load_files(const std::vector<std::string>& paths);

// Decimal places needed to print multiples of a number written as `text` ("0.01" -> 2, "1E-3" -> 3).
[[nodiscard]] int decimals_of(std::string_view number_text) noexcept;

}  // namespace sensor_rig::dbw::dbc
