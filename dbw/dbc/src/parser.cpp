// DBC parser: one function per statement kind, dispatched on the leading keyword.
#include "sensor_rig/dbw/dbc/parser.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <sstream>
#include <unordered_map>
#include <utility>

#include "cursor.hpp"
#include "sensor_rig/dbw/dbc/codec.hpp"

namespace sensor_rig::dbw::dbc {
namespace {

constexpr std::uint32_t kExtendedFlag = 0x80000000U;
constexpr std::uint32_t kMaxExtendedId = 0x1FFFFFFFU;
constexpr std::uint32_t kMaxStandardId = 0x7FFU;

// An integer written as a huge number (1e23: fuzz_dbc's find) saturates: casting a double outside
// int64's range is undefined behaviour, and no raw CAN value or enum key is that large.
std::int64_t saturating_int64(double v) noexcept {
  if (std::isnan(v)) return 0;
  if (v >= 9.2e18) return std::numeric_limits<std::int64_t>::max();
  if (v <= -9.2e18) return std::numeric_limits<std::int64_t>::min();
  return static_cast<std::int64_t>(v);
}

using detail::Cursor;

class Parser {
 public:
  Parser(std::string_view text, std::string_view source) : source_(source), c_(text, source_) {}

  Database run() {
    while (true) {
      c_.skip_space();
      if (c_.at_end()) break;
      const int line = c_.line();
      const std::string kw = c_.identifier("a DBC keyword");
      statement(kw, line);
    }
    finish();
    return std::move(db_);
  }

 private:
  void statement(const std::string& kw, int line) {
    if (kw == "VERSION") {
      db_.version = c_.quoted("VERSION");
    } else if (kw == "NS_") {
      new_symbols();
    } else if (kw == "BS_") {
      c_.expect(':', "after BS_");
      c_.skip_line();  // optional baudrate:BTR1,BTR2 (obsolete)
    } else if (kw == "BU_") {
      c_.expect(':', "after BU_");
      while (!c_.at_line_end()) db_.nodes.push_back(c_.identifier("node name"));
    } else if (kw == "BO_") {
      message(line);
    } else if (kw == "SG_") {
      if (current_ == kNone) c_.fail("SG_ before any BO_");
      signal(line);
    } else if (kw == "CM_") {
      comment();
    } else if (kw == "BA_DEF_") {
      attribute_definition();
    } else if (kw == "BA_DEF_DEF_") {
      attribute_default();
    } else if (kw == "BA_") {
      attribute_value();
    } else if (kw == "VAL_") {
      value_descriptions();
    } else if (kw == "VAL_TABLE_") {
      value_table();
    } else if (kw == "SIG_VALTYPE_") {
      signal_value_type();
    } else if (kw == "BO_TX_BU_") {
      transmitters();
    } else if (kw == "EV_" || kw == "ENVVAR_DATA_" || kw == "SGTYPE_" || kw == "SGTYPE_VAL_" ||
               kw == "SIG_GROUP_" || kw == "SG_MUL_VAL_" || kw == "SIG_TYPE_REF_" || kw == "BA_DEF_SGTYPE_" ||
               kw == "BA_SGTYPE_" || kw == "BA_DEF_REL_" || kw == "BA_REL_" || kw == "BA_DEF_DEF_REL_" ||
               kw == "BU_SG_REL_" || kw == "BU_EV_REL_" || kw == "BU_BO_REL_" || kw == "CAT_DEF_" || kw == "CAT_" ||
               kw == "FILTER" || kw == "SIGTYPE_VALTYPE_" || kw == "NS_DESC_" || kw == "ENVVAR_") {
      c_.skip_statement();  // known, not needed for encode/decode
    } else {
      c_.fail("unknown keyword '" + kw + "'");
    }
  }

  void new_symbols() {
    c_.expect(':', "after NS_");
    // The symbol list is indented; it ends at the next keyword in column one.
    while (c_.next_is_identifier() && !c_.at_column_one()) (void)c_.identifier("NS_ symbol");
  }

  void message(int line) {
    const std::uint64_t raw_id = c_.unsigned_integer("message id");
    Message m;
    m.line = line;
    if (raw_id > 0xFFFFFFFFULL) c_.fail("message id out of range");
    auto id = static_cast<std::uint32_t>(raw_id);
    m.extended = (id & kExtendedFlag) != 0;
    m.id = id & ~kExtendedFlag;
    if (m.extended ? m.id > kMaxExtendedId : m.id > kMaxStandardId) {
      // Standard ids above 0x7FF without the flag: some tools write 29-bit ids bare.
      if (!m.extended && m.id <= kMaxExtendedId) {
        m.extended = true;
      } else {
        c_.fail("message id " + std::to_string(raw_id) + " out of range");
      }
    }
    m.name = c_.identifier("message name");
    c_.expect(':', "after message name");
    const std::uint64_t size = c_.unsigned_integer("message size");
    if (size > kMaxFrameBytes) c_.fail("message size " + std::to_string(size) + " exceeds 64 bytes");
    m.size = static_cast<std::uint8_t>(size);
    m.sender = c_.identifier("transmitter");
    if (db_.find(m.id, m.extended) != nullptr) {
      c_.fail("duplicate message id " + std::to_string(m.id) + " (" + m.name + ")");
    }
    db_.messages.push_back(std::move(m));
    current_ = db_.messages.size() - 1;
  }

  void signal(int line) {
    Message* current = &db_.messages[current_];
    Signal s;
    s.line = line;
    s.name = c_.identifier("signal name");
    c_.skip_space();
    if (c_.peek() != ':') {
      const std::string mux = c_.identifier("multiplexer indicator");
      if (mux == "M") {
        s.mux = MuxRole::kMultiplexor;
      } else if (mux.size() >= 2 && mux[0] == 'm' && std::isdigit(static_cast<unsigned char>(mux[1])) != 0) {
        s.mux = MuxRole::kMultiplexed;
        std::size_t i = 1;
        std::uint64_t v = 0;
        while (i < mux.size() && std::isdigit(static_cast<unsigned char>(mux[i])) != 0) {
          v = v * 10 + static_cast<std::uint64_t>(mux[i] - '0');
          ++i;
        }
        s.mux_value = v;
        if (i != mux.size() && !(i + 1 == mux.size() && mux[i] == 'M')) {
          c_.fail("malformed multiplexer indicator '" + mux + "'");
        }
      } else {
        c_.fail("malformed multiplexer indicator '" + mux + "'");
      }
    }
    c_.expect(':', "after signal name");
    const std::uint64_t start = c_.unsigned_integer("start bit");
    c_.expect('|', "between start bit and length");
    const std::uint64_t len = c_.unsigned_integer("signal length");
    c_.expect('@', "before byte order");
    const char order = c_.get();
    const char sign = c_.get();
    if (order != '0' && order != '1') c_.fail("byte order must be 0 (Motorola) or 1 (Intel)");
    if (sign != '+' && sign != '-') c_.fail("value type must be + or -");
    if (len == 0 || len > 64) c_.fail("signal " + s.name + ": length " + std::to_string(len) + " not in 1..64");
    if (start >= kMaxFrameBytes * 8) c_.fail("signal " + s.name + ": start bit " + std::to_string(start) + " beyond 64 bytes");
    s.start_bit = static_cast<std::uint16_t>(start);
    s.length = static_cast<std::uint16_t>(len);
    s.order = order == '1' ? ByteOrder::kIntel : ByteOrder::kMotorola;
    s.is_signed = sign == '-';
    c_.expect('(', "before factor");
    const std::string_view ft = c_.number_text("factor");
    s.factor = to_double(ft);
    c_.expect(',', "between factor and offset");
    const std::string_view ot = c_.number_text("offset");
    s.offset = to_double(ot);
    c_.expect(')', "after offset");
    s.decimals = std::max(decimals_of(ft), decimals_of(ot));
    c_.expect('[', "before minimum");
    s.minimum = c_.number("minimum");
    c_.expect('|', "between minimum and maximum");
    s.maximum = c_.number("maximum");
    c_.expect(']', "after maximum");
    s.unit = c_.quoted("unit");
    while (!c_.at_line_end()) {
      s.receivers.push_back(c_.identifier("receiver"));
      c_.skip_blank();
      if (c_.peek() == ',') c_.get();
    }
    if (s.factor == 0.0) c_.fail("signal " + s.name + ": factor 0");
    if (!signal_fits(s, current->size)) {
      c_.fail("signal " + s.name + " (" + std::to_string(start) + "|" + std::to_string(len) + "@" + order +
              ") does not fit in " + std::to_string(current->size) + "-byte message " + current->name);
    }
    if (current->find(s.name) != nullptr) c_.fail("duplicate signal " + s.name + " in " + current->name);
    if (s.mux == MuxRole::kMultiplexor && current->multiplexor() != nullptr) {
      c_.fail("second multiplexor " + s.name + " in " + current->name);
    }
    current->signals.push_back(std::move(s));
  }

  double to_double(std::string_view t) {
    std::string s(t);
    if (!s.empty() && s[0] == '+') s.erase(0, 1);
    return std::strtod(s.c_str(), nullptr);
  }

  Message& message_ref(std::uint64_t raw_id) {
    const auto id = static_cast<std::uint32_t>(raw_id);
    Message* m = db_.find_mutable(id & ~kExtendedFlag, (id & kExtendedFlag) != 0);
    if (m == nullptr && (id & kExtendedFlag) == 0) m = db_.find_mutable(id, true);
    if (m == nullptr) c_.fail("reference to unknown message id " + std::to_string(raw_id));
    return *m;
  }

  Signal& signal_ref(Message& m, const std::string& name) {
    for (auto& s : m.signals) {
      if (s.name == name) return s;
    }
    c_.fail("reference to unknown signal " + m.name + "." + name);
  }

  void comment() {
    if (c_.next_is_string()) {
      db_.comment += c_.quoted("comment");
    } else {
      const std::string kind = c_.identifier("comment target");
      if (kind == "BU_") {
        const std::string node = c_.identifier("node name");
        db_.node_comments[node] = c_.quoted("comment");
      } else if (kind == "BO_") {
        Message& m = message_ref(c_.unsigned_integer("message id"));
        m.comment = c_.quoted("comment");
      } else if (kind == "SG_") {
        Message& m = message_ref(c_.unsigned_integer("message id"));
        Signal& s = signal_ref(m, c_.identifier("signal name"));
        s.comment = c_.quoted("comment");
      } else if (kind == "EV_") {
        (void)c_.identifier("environment variable");
        (void)c_.quoted("comment");
      } else {
        c_.fail("unknown comment target '" + kind + "'");
      }
    }
    c_.expect(';', "at end of CM_");
  }

  void attribute_definition() {
    AttributeDefinition d;
    if (c_.next_is_identifier()) {
      const std::string scope = c_.identifier("attribute scope");
      if (scope == "BU_") d.scope = AttributeScope::kNode;
      else if (scope == "BO_") d.scope = AttributeScope::kMessage;
      else if (scope == "SG_") d.scope = AttributeScope::kSignal;
      else if (scope == "EV_") d.scope = AttributeScope::kEnvVar;
      else c_.fail("unknown attribute scope '" + scope + "'");
    }
    d.name = c_.quoted("attribute name");
    const std::string kind = c_.identifier("attribute type");
    if (kind == "INT" || kind == "HEX" || kind == "FLOAT") {
      d.kind = kind == "INT" ? AttributeKind::kInteger : kind == "HEX" ? AttributeKind::kHex : AttributeKind::kFloating;
      d.minimum = c_.number("attribute minimum");
      d.maximum = c_.number("attribute maximum");
    } else if (kind == "STRING") {
      d.kind = AttributeKind::kString;
    } else if (kind == "ENUM") {
      d.kind = AttributeKind::kEnumeration;
      do {
        d.enum_values.push_back(c_.quoted("enum value"));
      } while (c_.accept(','));
    } else {
      c_.fail("unknown attribute type '" + kind + "'");
    }
    c_.expect(';', "at end of BA_DEF_");
    const std::string name = d.name;
    db_.attribute_definitions[name] = std::move(d);
  }

  AttributeValue attribute_literal(const std::string& name) {
    if (c_.next_is_string()) return c_.quoted("attribute value");
    const std::string_view t = c_.number_text("attribute value");
    const auto it = db_.attribute_definitions.find(name);
    const bool is_float = t.find_first_of(".eE") != std::string_view::npos ||
                          (it != db_.attribute_definitions.end() && it->second.kind == AttributeKind::kFloating);
    if (is_float) return to_double(t);
    return saturating_int64(to_double(t));
  }

  void attribute_default() {
    const std::string name = c_.quoted("attribute name");
    auto it = db_.attribute_definitions.find(name);
    if (it == db_.attribute_definitions.end()) c_.fail("default for undefined attribute \"" + name + "\"");
    it->second.default_value = attribute_literal(name);
    c_.expect(';', "at end of BA_DEF_DEF_");
  }

  void attribute_value() {
    const std::string name = c_.quoted("attribute name");
    if (db_.attribute_definitions.find(name) == db_.attribute_definitions.end()) {
      c_.fail("value for undefined attribute \"" + name + "\"");
    }
    Attributes* target = &db_.attributes;
    if (c_.next_is_identifier()) {
      const std::string kind = c_.identifier("attribute target");
      if (kind == "BU_") {
        (void)c_.identifier("node name");
        target = nullptr;  // node attributes are not used
      } else if (kind == "BO_") {
        target = &message_ref(c_.unsigned_integer("message id")).attributes;
      } else if (kind == "SG_") {
        Message& m = message_ref(c_.unsigned_integer("message id"));
        target = &signal_ref(m, c_.identifier("signal name")).attributes;
      } else if (kind == "EV_") {
        (void)c_.identifier("environment variable");
        target = nullptr;
      } else {
        c_.fail("unknown attribute target '" + kind + "'");
      }
    }
    AttributeValue v = attribute_literal(name);
    if (target != nullptr) (*target)[name] = std::move(v);
    c_.expect(';', "at end of BA_");
  }

  std::map<std::int64_t, std::string> value_list() {
    std::map<std::int64_t, std::string> out;
    while (!c_.accept(';')) {
      const auto v = saturating_int64(c_.number("value"));
      out[v] = c_.quoted("value description");
    }
    return out;
  }

  void value_descriptions() {
    if (c_.next_is_identifier()) {  // environment variable value descriptions
      (void)c_.identifier("environment variable");
      (void)value_list();
      return;
    }
    Message& m = message_ref(c_.unsigned_integer("message id"));
    Signal& s = signal_ref(m, c_.identifier("signal name"));
    s.value_names = value_list();
  }

  void value_table() {
    const std::string name = c_.identifier("value table name");
    db_.value_tables[name] = value_list();
  }

  void signal_value_type() {
    Message& m = message_ref(c_.unsigned_integer("message id"));
    Signal& s = signal_ref(m, c_.identifier("signal name"));
    c_.accept(':');
    const std::uint64_t t = c_.unsigned_integer("signal value type");
    if (t == 1) {
      if (s.length != 32) c_.fail("float signal " + s.name + " must be 32 bits");
      s.value_type = ValueType::kFloat32;
    } else if (t == 2) {
      if (s.length != 64) c_.fail("double signal " + s.name + " must be 64 bits");
      s.value_type = ValueType::kFloat64;
    } else if (t != 0) {
      c_.fail("signal value type must be 0, 1 or 2");
    }
    c_.expect(';', "at end of SIG_VALTYPE_");
  }

  void transmitters() {
    Message& m = message_ref(c_.unsigned_integer("message id"));
    c_.expect(':', "after message id");
    while (!c_.accept(';')) {
      m.transmitters.push_back(c_.identifier("transmitter"));
      c_.accept(',');
    }
  }

  void finish() {
    for (const auto& m : db_.messages) {
      bool has_multiplexed = false;
      for (const auto& s : m.signals) has_multiplexed = has_multiplexed || s.mux == MuxRole::kMultiplexed;
      if (has_multiplexed && m.multiplexor() == nullptr) {
        throw DbcError(source_name(), m.line, "message " + m.name + " has multiplexed signals but no multiplexor (M)");
      }
    }
  }

  [[nodiscard]] std::string source_name() const { return source_; }

  static constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  std::string source_;
  Cursor c_;
  Database db_;
  std::size_t current_ = kNone;  // index of the message SG_ lines attach to
};

}  // namespace
}  // namespace sensor_rig::dbw::dbc

namespace sensor_rig::dbw::dbc {

DbcError::DbcError(std::string src, int ln, const std::string& message)
    : std::runtime_error(src + ":" + std::to_string(ln) + ": " + message), source(std::move(src)), line(ln) {}

Database parse(std::string_view text, std::string_view source_name) {
  Parser p(text, source_name);
  return p.run();
}

Database load_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw DbcError(path, 0, "cannot open DBC file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse(ss.str(), path);
}

Database load_files(const std::vector<std::string>& paths) {
  Database out;
  for (const auto& path : paths) {
    Database db = load_file(path);
    for (auto& m : db.messages) {
      if (out.find(m.id, m.extended) != nullptr) {
        throw DbcError(path, m.line, "message id " + std::to_string(m.id) + " (" + m.name + ") already defined");
      }
      out.messages.push_back(std::move(m));
    }
    for (auto& [k, v] : db.attribute_definitions) out.attribute_definitions.try_emplace(k, std::move(v));
    for (auto& [k, v] : db.value_tables) out.value_tables.try_emplace(k, std::move(v));
    out.nodes.insert(out.nodes.end(), db.nodes.begin(), db.nodes.end());
    if (out.version.empty()) out.version = db.version;
  }
  return out;
}

int decimals_of(std::string_view t) noexcept {
  int exponent = 0;
  const std::size_t e = t.find_first_of("eE");
  if (e != std::string_view::npos) {
    std::string_view ex = t.substr(e + 1);
    bool neg = false;
    if (!ex.empty() && (ex[0] == '-' || ex[0] == '+')) {
      neg = ex[0] == '-';
      ex.remove_prefix(1);
    }
    // Saturates: a 10-digit exponent (found by fuzz_dbc) overflowed int; beyond ~400 a double
    // is 0 or inf anyway, and a factor that small or large is refused where it is used.
    for (char c : ex)
      if (exponent < 100'000) exponent = exponent * 10 + (c - '0');
    if (neg) exponent = -exponent;
    t = t.substr(0, e);
  }
  int frac = 0;
  const std::size_t dot = t.find('.');
  if (dot != std::string_view::npos) {
    std::string_view f = t.substr(dot + 1);
    while (!f.empty() && f.back() == '0') f.remove_suffix(1);
    frac = static_cast<int>(f.size());
  }
  return std::max(0, frac - exponent);
}

}  // namespace sensor_rig::dbw::dbc
