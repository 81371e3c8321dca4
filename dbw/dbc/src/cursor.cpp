#include "cursor.hpp"

#include <cctype>
#include <charconv>
#include <cstdlib>
#include <limits>

#include "sensor_rig/dbw/dbc/parser.hpp"

namespace sensor_rig::dbw::dbc::detail {
namespace {
bool ident_start(char c) { return std::isalpha(static_cast<unsigned char>(c)) != 0 || c == '_'; }
bool ident_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_'; }
bool digit(char c) { return c >= '0' && c <= '9'; }
}  // namespace

char Cursor::advance() noexcept {
  const char c = text_[pos_++];
  if (c == '\n') ++line_;
  return c;
}

bool Cursor::skip_space() {
  bool newline = false;
  while (!at_end()) {
    const char c = text_[pos_];
    if (c == '\n') newline = true;
    if (c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v') {
      advance();
    } else {
      break;
    }
  }
  return newline;
}

void Cursor::skip_blank() {
  while (!at_end() && (text_[pos_] == ' ' || text_[pos_] == '\t' || text_[pos_] == '\r')) advance();
}

bool Cursor::at_line_start() const noexcept {
  std::size_t p = pos_;
  while (p > 0) {
    const char c = text_[p - 1];
    if (c == '\n') return true;
    if (c != ' ' && c != '\t' && c != '\r') return false;
    --p;
  }
  return true;
}

bool Cursor::at_line_end() {
  skip_blank();
  return at_end() || peek() == '\n' || peek() == ';';
}

void Cursor::fail(const std::string& message) const { throw DbcError(std::string(source_), line_, message); }

std::string Cursor::identifier(std::string_view what) {
  skip_space();
  if (at_end() || !ident_start(peek())) fail("expected " + std::string(what));
  const std::size_t b = pos_;
  while (!at_end() && ident_char(peek())) advance();
  return std::string(text_.substr(b, pos_ - b));
}

bool Cursor::next_is_identifier() {
  skip_space();
  return !at_end() && ident_start(peek());
}

bool Cursor::next_is_number() {
  skip_space();
  if (at_end()) return false;
  const char c = peek();
  if (digit(c)) return true;
  if ((c == '-' || c == '+' || c == '.') && pos_ + 1 < text_.size()) {
    const char n = text_[pos_ + 1];
    return digit(n) || (n == '.' && c != '.');
  }
  return false;
}

bool Cursor::next_is_string() {
  skip_space();
  return peek() == '"';
}

std::string_view Cursor::number_text(std::string_view what) {
  if (!next_is_number()) fail("expected " + std::string(what));
  const std::size_t b = pos_;
  if (peek() == '-' || peek() == '+') advance();
  while (!at_end() && (digit(peek()) || peek() == '.')) advance();
  if (!at_end() && (peek() == 'e' || peek() == 'E')) {
    advance();
    if (peek() == '-' || peek() == '+') advance();
    if (!digit(peek())) fail("malformed exponent in " + std::string(what));
    while (!at_end() && digit(peek())) advance();
  }
  return text_.substr(b, pos_ - b);
}

double Cursor::number(std::string_view what) {
  std::string s(number_text(what));
  if (!s.empty() && s[0] == '+') s.erase(0, 1);
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end != s.c_str() + s.size()) fail("malformed number '" + s + "' for " + std::string(what));
  return v;
}

std::int64_t Cursor::integer(std::string_view what) {
  const std::string_view t = number_text(what);
  std::string_view s = t;
  if (!s.empty() && s[0] == '+') s.remove_prefix(1);
  std::int64_t v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec != std::errc{} || r.ptr != s.data() + s.size()) {
    fail("expected an integer for " + std::string(what) + ", got '" + std::string(t) + "'");
  }
  return v;
}

std::uint64_t Cursor::unsigned_integer(std::string_view what) {
  const std::string_view t = number_text(what);
  std::uint64_t v = 0;
  const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
  if (r.ec != std::errc{} || r.ptr != t.data() + t.size()) {
    fail("expected an unsigned integer for " + std::string(what) + ", got '" + std::string(t) + "'");
  }
  return v;
}

std::string Cursor::quoted(std::string_view what) {
  skip_space();
  if (peek() != '"') fail("expected a quoted string for " + std::string(what));
  const int start_line = line_;
  advance();
  std::string out;
  while (true) {
    if (at_end()) throw DbcError(std::string(source_), start_line, "unterminated string for " + std::string(what));
    const char c = advance();
    if (c == '"') break;
    if (c == '\\' && !at_end() && (peek() == '"' || peek() == '\\')) {
      out.push_back(advance());
      continue;
    }
    if (c != '\r') out.push_back(c);
  }
  return out;
}

void Cursor::expect(char c, std::string_view what) {
  skip_space();
  if (at_end() || peek() != c) {
    fail("expected '" + std::string(1, c) + "' " + std::string(what) +
         (at_end() ? std::string(", got end of file") : ", got '" + std::string(1, peek()) + "'"));
  }
  advance();
}

bool Cursor::accept(char c) {
  skip_space();
  if (!at_end() && peek() == c) {
    advance();
    return true;
  }
  return false;
}

void Cursor::skip_statement() {
  const int start = line_;
  while (!at_end()) {
    const char c = peek();
    if (c == '"') {
      quoted("string");
      continue;
    }
    advance();
    if (c == ';') return;
  }
  throw DbcError(std::string(source_), start, "statement not terminated by ';'");
}

void Cursor::skip_line() {
  while (!at_end() && peek() != '\n') advance();
}

}  // namespace sensor_rig::dbw::dbc::detail
