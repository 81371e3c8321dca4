#include "sensor_rig/msgs/ros2msg.hpp"

#include <algorithm>
#include <charconv>
#include <set>
#include <stdexcept>

#include "msg_texts.hpp"

namespace sensor_rig::msgs {
namespace {

constexpr std::string_view kSeparator =
    "================================================================================";

bool is_primitive_name(std::string_view t) {
  static constexpr std::string_view kPrimitives[] = {
      "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
      "int32", "uint32", "int64", "uint64", "string", "wstring"};
  return std::find(std::begin(kPrimitives), std::end(kPrimitives), t) != std::end(kPrimitives);
}

std::string_view trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string_view::npos) return {};
  return s.substr(b, s.find_last_not_of(" \t\r") - b + 1);
}

[[noreturn]] void fail(std::string_view name, int line, const std::string& what) {
  throw std::invalid_argument(std::string(name) + " line " + std::to_string(line) + ": " + what);
}

std::uint32_t parse_count(std::string_view s, std::string_view name, int line) {
  std::uint32_t v = 0;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || p != s.data() + s.size()) fail(name, line, "bad array size '" + std::string(s) + "'");
  return v;
}

// One field line "TYPE NAME [DEFAULT]" (comment stripped, not a constant) into f.
MsgField parse_field(std::string_view pkg, std::string_view name, int line, std::string_view type_tok,
                     std::string_view field_tok) {
  MsgField f;
  f.name = std::string(field_tok);
  if (const auto br = type_tok.find('['); br != std::string_view::npos) {
    if (type_tok.back() != ']') fail(name, line, "unclosed '[' in '" + std::string(type_tok) + "'");
    std::string_view inside = type_tok.substr(br + 1, type_tok.size() - br - 2);
    if (inside.empty()) {
      f.kind = MsgField::Kind::kSequence;
    } else if (inside.starts_with("<=")) {
      f.kind = MsgField::Kind::kSequence;
      f.size = parse_count(inside.substr(2), name, line);
    } else {
      f.kind = MsgField::Kind::kArray;
      f.size = parse_count(inside, name, line);
    }
    type_tok = type_tok.substr(0, br);
  }
  if (const auto le = type_tok.find("<="); le != std::string_view::npos) {
    f.string_bound = parse_count(type_tok.substr(le + 2), name, line);
    type_tok = type_tok.substr(0, le);
    if (type_tok != "string" && type_tok != "wstring") fail(name, line, "only strings take a bound");
  }
  if (is_primitive_name(type_tok)) {
    f.type = std::string(type_tok);
  } else if (type_tok == "Header") {
    f.type = "std_msgs/Header";
  } else if (type_tok.find('/') == std::string_view::npos) {
    f.type = std::string(pkg) + "/" + std::string(type_tok);
  } else {
    f.type = short_name(type_tok);
    if (f.type.empty()) fail(name, line, "bad type name '" + std::string(type_tok) + "'");
  }
  return f;
}

void collect_dependencies(const MsgDefinition& def, std::set<std::string>& seen, std::vector<std::string>& order,
                          bool& missing) {
  for (const auto& f : def.fields) {
    if (f.is_primitive() || !seen.insert(f.type).second) continue;
    const auto text = msg_text(f.type);
    if (!text) {
      missing = true;
      return;
    }
    order.push_back(f.type);
    collect_dependencies(parse_msg(f.type, *text), seen, order, missing);
  }
}

}  // namespace

std::string short_name(std::string_view n) {
  const auto a = n.find('/');
  if (a == std::string_view::npos || a == 0) return {};
  const auto b = n.find('/', a + 1);
  if (b == std::string_view::npos) return a + 1 < n.size() ? std::string(n) : std::string();
  if (n.substr(a + 1, b - a - 1) != "msg" || b + 1 >= n.size() || n.find('/', b + 1) != std::string_view::npos) return {};
  return std::string(n.substr(0, a)) + "/" + std::string(n.substr(b + 1));
}

std::string schema_name(std::string_view n) {
  const std::string s = short_name(n);
  if (s.empty()) return {};
  const auto a = s.find('/');
  return s.substr(0, a) + "/msg/" + s.substr(a + 1);
}

MsgDefinition parse_msg(std::string_view name, std::string_view text) {
  MsgDefinition def;
  def.name = short_name(name);
  if (def.name.empty()) throw std::invalid_argument("bad message type name '" + std::string(name) + "'");
  const std::string_view pkg = std::string_view(def.name).substr(0, def.name.find('/'));
  int line_no = 0;
  while (!text.empty()) {
    const auto nl = text.find('\n');
    std::string_view line = text.substr(0, nl);
    text = nl == std::string_view::npos ? std::string_view{} : text.substr(nl + 1);
    ++line_no;
    if (const auto hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    line = trim(line);
    if (line.empty()) continue;
    const auto sp = line.find_first_of(" \t");
    if (sp == std::string_view::npos) fail(def.name, line_no, "a field needs a type and a name");
    const std::string_view type_tok = line.substr(0, sp);
    std::string_view rest = trim(line.substr(sp));
    const auto eq = rest.find('=');
    const auto name_end = rest.find_first_of(" \t=");
    const std::string_view field_tok = rest.substr(0, name_end);
    if (field_tok.empty()) fail(def.name, line_no, "a field needs a name");
    // A constant: NAME=VALUE with nothing but blanks between the name and '='.
    if (eq != std::string_view::npos && trim(rest.substr(field_tok.size(), eq - field_tok.size())).empty()) continue;
    def.fields.push_back(parse_field(pkg, def.name, line_no, type_tok, field_tok));
  }
  return def;
}

std::vector<MsgDefinition> parse_ros2msg_schema(std::string_view name, std::string_view schema) {
  std::vector<MsgDefinition> defs;
  std::string section = short_name(name);
  std::size_t start = 0;
  for (;;) {
    const auto sep = schema.find(kSeparator, start);
    const std::string_view body =
        schema.substr(start, sep == std::string_view::npos ? std::string_view::npos : sep - start);
    defs.push_back(parse_msg(section, body));
    if (sep == std::string_view::npos) break;
    auto line_end = schema.find('\n', sep);
    if (line_end == std::string_view::npos) throw std::invalid_argument(section + ": separator at the end of the schema");
    const auto header_end = schema.find('\n', line_end + 1);
    const std::string_view header = trim(schema.substr(line_end + 1, header_end - line_end - 1));
    if (!header.starts_with("MSG:")) throw std::invalid_argument(section + ": separator not followed by 'MSG: pkg/Type'");
    section = short_name(trim(header.substr(4)));
    if (section.empty()) throw std::invalid_argument("bad section name '" + std::string(header) + "'");
    if (header_end == std::string_view::npos) {
      defs.push_back(MsgDefinition{section, {}});
      break;
    }
    start = header_end + 1;
  }
  return defs;
}

std::optional<std::string_view> msg_text(std::string_view name) {
  const std::string s = short_name(name);
  for (std::size_t i = 0; i < detail::kEmbeddedMsgCount; ++i)
    if (detail::kEmbeddedMsgs[i].name == s) return detail::kEmbeddedMsgs[i].text;
  return std::nullopt;
}

std::vector<std::string_view> embedded_msg_names() {
  std::vector<std::string_view> names;
  for (std::size_t i = 0; i < detail::kEmbeddedMsgCount; ++i) names.push_back(detail::kEmbeddedMsgs[i].name);
  std::sort(names.begin(), names.end());
  return names;
}

std::optional<std::string> ros2msg_schema(std::string_view name) {
  const auto text = msg_text(name);
  if (!text) return std::nullopt;
  const std::string root = short_name(name);
  std::set<std::string> seen{root};
  std::vector<std::string> order;
  bool missing = false;
  collect_dependencies(parse_msg(root, *text), seen, order, missing);
  if (missing) return std::nullopt;
  std::string out(*text);
  for (const auto& dep : order) {
    out += '\n';
    out += kSeparator;
    out += "\nMSG: ";
    out += dep;
    out += '\n';
    out += *msg_text(dep);
  }
  return out;
}

}  // namespace sensor_rig::msgs
