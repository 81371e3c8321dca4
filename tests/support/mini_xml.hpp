#pragma once
// A strict little XML reader for checking the SVG the project writes: elements, quoted attributes,
// text, the five predefined entities and numeric ones, an optional <?xml ...?> prolog. No DTDs,
// CDATA or comments (the writers emit none). Throws std::runtime_error on anything malformed.
#include <cctype>
#include <functional>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace sensor_rig::test::xml {

struct Element {
  std::string name;
  std::map<std::string, std::string> attrs;
  std::vector<std::unique_ptr<Element>> children;
  std::string text;  // character data directly inside, entities decoded

  [[nodiscard]] double num(const std::string& attr) const { return std::stod(attrs.at(attr)); }
  // Every element below (and including) this one, depth first.
  void each(const std::function<void(const Element&)>& fn) const {
    fn(*this);
    for (const auto& c : children) c->each(fn);
  }
  // All text below this element, concatenated.
  [[nodiscard]] std::string all_text() const {
    std::string t = text;
    for (const auto& c : children) t += c->all_text();
    return t;
  }
};

namespace detail {
class Parser {
 public:
  explicit Parser(std::string_view s) : s_(s) {}
  std::unique_ptr<Element> document() {
    skip_space();
    if (s_.substr(i_, 5) == "<?xml") {
      const auto end = s_.find("?>", i_);
      if (end == std::string_view::npos) fail("unterminated prolog");
      i_ = end + 2;
    }
    skip_space();
    auto root = element();
    skip_space();
    if (i_ != s_.size()) fail("content after the root element");
    return root;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error("xml: " + what + " at offset " + std::to_string(i_));
  }
  void skip_space() {
    while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_])) != 0) ++i_;
  }
  void expect(char c) {
    if (i_ >= s_.size() || s_[i_] != c) fail(std::string("expected '") + c + "'");
    ++i_;
  }
  std::string name() {
    const std::size_t start = i_;
    while (i_ < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[i_])) != 0 || s_[i_] == '-' ||
                              s_[i_] == '_' || s_[i_] == ':' || s_[i_] == '.'))
      ++i_;
    if (i_ == start) fail("expected a name");
    return std::string(s_.substr(start, i_ - start));
  }
  std::string decode(std::string_view raw) {
    std::string out;
    for (std::size_t k = 0; k < raw.size(); ++k) {
      if (raw[k] == '<') fail("'<' in character data");
      if (raw[k] != '&') {
        out += raw[k];
        continue;
      }
      const auto semi = raw.find(';', k);
      if (semi == std::string_view::npos) fail("unterminated entity");
      const std::string_view ent = raw.substr(k + 1, semi - k - 1);
      if (ent == "lt") out += '<';
      else if (ent == "gt") out += '>';
      else if (ent == "amp") out += '&';
      else if (ent == "apos") out += '\'';
      else if (ent == "quot") out += '"';
      else if (ent.size() > 1 && ent[0] == '#') out += static_cast<char>(std::stoi(std::string(ent.substr(1))));
      else fail("unknown entity &" + std::string(ent) + ";");
      k = semi;
    }
    return out;
  }
  std::unique_ptr<Element> element() {
    expect('<');
    auto e = std::make_unique<Element>();
    e->name = name();
    for (;;) {
      skip_space();
      if (i_ >= s_.size()) fail("unterminated tag");
      if (s_[i_] == '/') {
        ++i_;
        expect('>');
        return e;
      }
      if (s_[i_] == '>') {
        ++i_;
        break;
      }
      const std::string key = name();
      skip_space();
      expect('=');
      skip_space();
      if (i_ >= s_.size() || (s_[i_] != '\'' && s_[i_] != '"')) fail("unquoted attribute " + key);
      const char q = s_[i_++];
      const auto end = s_.find(q, i_);
      if (end == std::string_view::npos) fail("unterminated attribute " + key);
      if (!e->attrs.emplace(key, decode(s_.substr(i_, end - i_))).second) fail("duplicate attribute " + key);
      i_ = end + 1;
    }
    for (;;) {
      const auto lt = s_.find('<', i_);
      if (lt == std::string_view::npos) fail("unclosed <" + e->name + ">");
      e->text += decode(s_.substr(i_, lt - i_));
      i_ = lt;
      if (s_.substr(i_, 2) == "</") {
        i_ += 2;
        if (name() != e->name) fail("mismatched </...> for <" + e->name + ">");
        skip_space();
        expect('>');
        return e;
      }
      e->children.push_back(element());
    }
  }

  std::string_view s_;
  std::size_t i_ = 0;
};
}  // namespace detail

inline std::unique_ptr<Element> parse(std::string_view text) { return detail::Parser(text).document(); }

}  // namespace sensor_rig::test::xml
