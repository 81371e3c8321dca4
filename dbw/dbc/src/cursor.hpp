#pragma once
// A character cursor over DBC text with line tracking; the parser pulls tokens as it needs them.
#include <cstdint>
#include <string>
#include <string_view>

namespace sensor_rig::dbw::dbc::detail {

class Cursor {
 public:
  Cursor(std::string_view text, std::string_view source) : text_(text), source_(source) {}

  // Skips spaces, tabs, CR/LF; returns true if a newline was crossed.
  bool skip_space();
  // Skips spaces and tabs only (stays on the line).
  void skip_blank();
  [[nodiscard]] bool at_end() const noexcept { return pos_ >= text_.size(); }
  [[nodiscard]] char peek() const noexcept { return at_end() ? '\0' : text_[pos_]; }
  [[nodiscard]] int line() const noexcept { return line_; }
  [[nodiscard]] bool at_line_start() const noexcept;  // only blanks before the cursor on this line
  [[nodiscard]] bool at_column_one() const noexcept { return pos_ == 0 || text_[pos_ - 1] == '\n'; }
  [[nodiscard]] bool at_line_end();                   // after blanks: newline, ';' or end

  // Token readers; each skips leading whitespace (including newlines) and throws DbcError on mismatch.
  std::string identifier(std::string_view what);
  std::string_view number_text(std::string_view what);
  double number(std::string_view what);
  std::int64_t integer(std::string_view what);
  std::uint64_t unsigned_integer(std::string_view what);
  std::string quoted(std::string_view what);
  void expect(char c, std::string_view what);
  bool accept(char c);  // consumes c (after whitespace) if it is next
  [[nodiscard]] bool next_is_identifier();
  [[nodiscard]] bool next_is_number();
  [[nodiscard]] bool next_is_string();
  // Skips to and past the next ';' outside strings.
  void skip_statement();
  void skip_line();
  char get() noexcept { return at_end() ? '\0' : advance(); }

  [[noreturn]] void fail(const std::string& message) const;

 private:
  char advance() noexcept;
  std::string_view text_;
  std::string_view source_;
  std::size_t pos_ = 0;
  int line_ = 1;
};

}  // namespace sensor_rig::dbw::dbc::detail
