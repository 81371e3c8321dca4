#include <cmath>
#include <filesystem>
#include <sstream>

#include "sensor_rig/common/errors.hpp"
#include "sensor_rig/common/config_node.hpp"

namespace sensor_rig::config {

std::string Problem::str() const {
  std::ostringstream out;
  out << file << ':' << line << ':' << column << ": " << (key.empty() ? "<root>" : key) << ": " << message;
  return out.str();
}

std::string Problems::str() const {
  std::string s;
  for (const auto& p : items_) s += p.str() + "\n";
  return s;
}

void Problems::throw_if_any() const {
  if (!items_.empty()) throw ConfigError(str());
}

Node::Node(const YAML::Node& node, std::shared_ptr<const std::string> file, std::string path,
           std::shared_ptr<Problems> problems)
    // YAML::Node is a handle (no move constructor): copying it shares the tree.
    : node_(node), file_(std::move(file)), path_(std::move(path)), problems_(std::move(problems)) {}

Node Node::load_file(const std::string& path, const std::shared_ptr<Problems>& problems) {
  auto file = std::make_shared<const std::string>(path);
  try {
    return Node(YAML::LoadFile(path), file, "", problems);
  } catch (const YAML::BadFile&) {
    problems->add({path, 0, 0, "", "cannot open file"});
  } catch (const YAML::Exception& e) {
    problems->add({path, e.mark.line + 1, e.mark.column + 1, "", "YAML syntax: " + e.msg});
  }
  return Node(YAML::Node(), file, "", problems);
}

Node Node::load_string(const std::string& text, const std::string& name, const std::shared_ptr<Problems>& problems) {
  auto file = std::make_shared<const std::string>(name);
  try {
    return Node(YAML::Load(text), file, "", problems);
  } catch (const YAML::Exception& e) {
    problems->add({name, e.mark.line + 1, e.mark.column + 1, "", "YAML syntax: " + e.msg});
  }
  return Node(YAML::Node(), file, "", problems);
}

std::string Node::key_path(std::string_view key) const {
  if (key.empty()) return path_;
  if (path_.empty()) return std::string(key);
  return path_ + "." + std::string(key);
}

void Node::fail(std::string_view key, std::string message) const {
  YAML::Mark mark = node_.IsDefined() ? node_.Mark() : YAML::Mark::null_mark();
  if (!key.empty() && node_.IsMap()) {
    // Point at the key itself when it exists, else at the enclosing map.
    for (const auto& kv : node_) {
      if (kv.first.Scalar() == key) {
        mark = kv.second.IsDefined() ? kv.second.Mark() : kv.first.Mark();
        break;
      }
    }
  }
  const int line = mark.line >= 0 ? mark.line + 1 : 0;
  const int col = mark.column >= 0 ? mark.column + 1 : 0;
  problems_->add({*file_, line, col, key_path(key), std::move(message)});
}

bool Node::has(std::string_view key) const {
  if (!node_.IsMap()) return false;
  const auto v = node_[std::string(key)];
  return v.IsDefined() && !v.IsNull();
}

YAML::Node Node::raw(std::string_view key) const {
  if (!node_.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
  return node_[std::string(key)];
}

bool Node::expect_map() const {
  if (node_.IsMap()) return true;
  if (node_.IsDefined()) fail("", "expected a map of keys");
  return false;
}

void Node::allow_keys(std::initializer_list<std::string_view> allowed) const {
  if (!node_.IsMap()) return;
  for (const auto& kv : node_) {
    const std::string k = kv.first.Scalar();
    bool ok = false;
    for (auto a : allowed) ok = ok || a == k;
    if (!ok) {
      std::string list;
      for (auto a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
      const auto m = kv.first.Mark();
      problems_->add({*file_, m.line + 1, m.column + 1, key_path(k), "unknown key (allowed: " + list + ")"});
    }
  }
}

std::optional<Node> Node::child(std::string_view key, bool required) const {
  const auto v = raw(key);
  if (!v.IsDefined() || v.IsNull()) {
    if (required) fail(key, "required key is missing");
    return std::nullopt;
  }
  if (!v.IsMap()) {
    fail(key, "expected a map");
    return std::nullopt;
  }
  return Node(v, file_, key_path(key), problems_);
}

std::vector<Node> Node::items(std::string_view key, bool required) const {
  std::vector<Node> out;
  const auto v = raw(key);
  if (!v.IsDefined() || v.IsNull()) {
    if (required) fail(key, "required key is missing");
    return out;
  }
  if (!v.IsSequence()) {
    fail(key, "expected a list");
    return out;
  }
  for (std::size_t i = 0; i < v.size(); ++i)
    out.emplace_back(v[i], file_, key_path(key) + "[" + std::to_string(i) + "]", problems_);
  return out;
}

std::string Node::get_string(std::string_view key, const std::optional<std::string>& fallback) const {
  const auto v = raw(key);
  if (!v.IsDefined() || v.IsNull()) {
    if (!fallback) fail(key, "required key is missing");
    return fallback.value_or("");
  }
  if (!v.IsScalar()) {
    fail(key, "expected a string");
    return fallback.value_or("");
  }
  return v.Scalar();
}

bool Node::get_bool(std::string_view key, std::optional<bool> fallback) const {
  const auto v = raw(key);
  if (!v.IsDefined() || v.IsNull()) {
    if (!fallback) fail(key, "required key is missing");
    return fallback.value_or(false);
  }
  bool b = false;
  if (!v.IsScalar() || !YAML::convert<bool>::decode(v, b)) {
    fail(key, "expected true or false, got '" + (v.IsScalar() ? v.Scalar() : std::string("<non-scalar>")) + "'");
    return fallback.value_or(false);
  }
  return b;
}

std::int64_t Node::get_int(std::string_view key, std::int64_t lo, std::int64_t hi,
                           std::optional<std::int64_t> fallback) const {
  const auto v = raw(key);
  if (!v.IsDefined() || v.IsNull()) {
    if (!fallback) fail(key, "required key is missing");
    return fallback.value_or(lo);
  }
  std::int64_t x = 0;
  if (!v.IsScalar() || !YAML::convert<std::int64_t>::decode(v, x)) {
    fail(key, "expected an integer, got '" + (v.IsScalar() ? v.Scalar() : std::string("<non-scalar>")) + "'");
    return fallback.value_or(lo);
  }
  if (x < lo || x > hi) {
    fail(key, "value " + std::to_string(x) + " out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return fallback.value_or(lo);
  }
  return x;
}

double Node::get_double(std::string_view key, double lo, double hi, std::optional<double> fallback) const {
  const auto v = raw(key);
  if (!v.IsDefined() || v.IsNull()) {
    if (!fallback) fail(key, "required key is missing");
    return fallback.value_or(lo);
  }
  double x = 0;
  if (!v.IsScalar() || !YAML::convert<double>::decode(v, x) || !std::isfinite(x)) {
    fail(key, "expected a finite number, got '" + (v.IsScalar() ? v.Scalar() : std::string("<non-scalar>")) + "'");
    return fallback.value_or(lo);
  }
  if (x < lo || x > hi) {
    std::ostringstream m;
    m << "value " << x << " out of range [" << lo << ", " << hi << "]";
    fail(key, m.str());
    return fallback.value_or(lo);
  }
  return x;
}

std::string Node::get_choice(std::string_view key, std::initializer_list<std::string_view> choices,
                             const std::optional<std::string>& fallback) const {
  return get_choice_of(key, std::vector<std::string_view>(choices), fallback);
}

std::string Node::get_choice_of(std::string_view key, const std::vector<std::string_view>& choices,
                                const std::optional<std::string>& fallback) const {
  const bool present = has(key);
  std::string s = get_string(key, fallback);
  if (!present) return s;
  for (auto c : choices)
    if (c == s) return s;
  std::string list;
  for (auto c : choices) list += (list.empty() ? "" : ", ") + std::string(c);
  fail(key, "'" + s + "' is not one of: " + list);
  return fallback.value_or(choices.empty() ? std::string() : std::string(choices.front()));
}

std::string Node::get_path(std::string_view key, const std::optional<std::string>& fallback) const {
  const bool present = has(key);
  std::string s = get_string(key, fallback);
  if (!present || s.empty()) return s;
  std::filesystem::path p(s);
  if (p.is_relative()) p = std::filesystem::path(*file_).parent_path() / p;
  return p.lexically_normal().string();
}

}  // namespace sensor_rig::config
