#pragma once
// Validated YAML config reading. Every error names file:line:column and the dotted key path;
// errors are collected so one `rig config check` run reports all of them.
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <functional>
#include <initializer_list>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace sensor_rig::config {

struct Problem {
  std::string file;
  int line = 0;    // 1-based
  int column = 0;  // 1-based
  std::string key;
  std::string message;
  [[nodiscard]] std::string str() const;  // "file:line:col: key: message"
};

class Problems {
 public:
  void add(Problem p) { items_.push_back(std::move(p)); }
  [[nodiscard]] bool empty() const { return items_.empty(); }
  [[nodiscard]] const std::vector<Problem>& items() const { return items_; }
  [[nodiscard]] std::string str() const;
  // Throws ConfigError listing every problem, if any.
  void throw_if_any() const;

 private:
  std::vector<Problem> items_;
};

class Node {
 public:
  Node(const YAML::Node& node, std::shared_ptr<const std::string> file, std::string path,
       std::shared_ptr<Problems> problems);

  // Loads a YAML file; a syntax error becomes a Problem with its position.
  static Node load_file(const std::string& path, const std::shared_ptr<Problems>& problems);
  static Node load_string(const std::string& text, const std::string& name, const std::shared_ptr<Problems>& problems);

  [[nodiscard]] bool valid() const { return node_.IsDefined() && !node_.IsNull(); }
  [[nodiscard]] bool has(std::string_view key) const;
  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] const std::string& file() const { return *file_; }
  [[nodiscard]] const YAML::Node& yaml() const { return node_; }
  [[nodiscard]] Problems& problems() const { return *problems_; }

  // Reports every key of this map that is not in `allowed`.
  void allow_keys(std::initializer_list<std::string_view> allowed) const;
  // Requires this node to be a map (or a sequence); reports otherwise.
  bool expect_map() const;

  [[nodiscard]] std::optional<Node> child(std::string_view key, bool required = false) const;
  [[nodiscard]] std::vector<Node> items(std::string_view key, bool required = false) const;

  std::string get_string(std::string_view key, const std::optional<std::string>& fallback = std::nullopt) const;
  bool get_bool(std::string_view key, std::optional<bool> fallback = std::nullopt) const;
  std::int64_t get_int(std::string_view key, std::int64_t lo, std::int64_t hi,
                       std::optional<std::int64_t> fallback = std::nullopt) const;
  double get_double(std::string_view key, double lo, double hi, std::optional<double> fallback = std::nullopt) const;
  // One of `choices`; reports the allowed values otherwise.
  std::string get_choice(std::string_view key, std::initializer_list<std::string_view> choices,
                         const std::optional<std::string>& fallback = std::nullopt) const;
  // One of `choices` as its enum value: text becomes an enum at load time, never compared later.
  template <class E>
  E get_enum(std::string_view key, std::initializer_list<std::pair<std::string_view, E>> choices, E fallback) const {
    std::vector<std::string_view> words;
    std::string fallback_word;
    for (const auto& [word, value] : choices) {
      words.push_back(word);
      if (value == fallback) fallback_word = std::string(word);
    }
    const std::string got = get_choice_of(key, words, fallback_word);
    for (const auto& [word, value] : choices)
      if (got == word) return value;
    return fallback;  // reported as a problem by get_choice_of
  }
  // A path relative to the config file's directory (absolute paths pass through).
  std::string get_path(std::string_view key, const std::optional<std::string>& fallback = std::nullopt) const;

  // Reports a problem at `key` (or at this node when key is empty).
  void fail(std::string_view key, std::string message) const;

 private:
  std::string get_choice_of(std::string_view key, const std::vector<std::string_view>& choices,
                            const std::optional<std::string>& fallback) const;
  [[nodiscard]] std::string key_path(std::string_view key) const;
  [[nodiscard]] YAML::Node raw(std::string_view key) const;

  YAML::Node node_;
  std::shared_ptr<const std::string> file_;
  std::string path_;
  std::shared_ptr<Problems> problems_;
};

}  // namespace sensor_rig::config
