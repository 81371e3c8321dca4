// VeloView calibration XML (boost::serialization of the DB): distLSB_ in cm, and per laser a
// <px> with id_, rotCorrection_ / vertCorrection_ in degrees and distances/offsets in cm.
// A small tag scanner is enough for this machine-written format; it tracks lines for errors.
#include <charconv>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "sensor_rig/common/angles.hpp"
#include "sensor_rig/lidar/velodyne/calibration.hpp"

namespace sensor_rig::lidar::velodyne {
namespace {

class XmlScanner {
 public:
  XmlScanner(std::string_view text, const std::string& source) : text_(text), source_(source) {}

  Calibration run() {
    Calibration c;
    c.source = source_;
    bool have_lsb = false;
    std::optional<LaserCorrection> laser;
    bool laser_has_id = false;
    std::string_view pending_text;
    while (pos_ < text_.size()) {
      const auto lt = text_.find('<', pos_);
      if (lt == std::string_view::npos) break;
      advance_to(lt);
      pending_text = text_.substr(text_start_, lt - text_start_);
      if (starts_with("<?")) {
        skip_past("?>");
      } else if (starts_with("<!--")) {
        skip_past("-->");
      } else if (starts_with("<!")) {
        skip_past(">");
      } else if (starts_with("</")) {
        const auto name = tag_name(2);
        skip_past(">");
        if (stack_.empty() || stack_.back() != name) {
          std::string msg = "closing tag </";
          msg.append(name).append("> does not match ");
          if (stack_.empty()) {
            msg.append("anything");
          } else {
            msg.append("<").append(stack_.back()).append(">");
          }
          fail(msg);
        }
        const std::string_view parent = stack_.size() >= 2 ? stack_[stack_.size() - 2] : std::string_view{};
        if (name == "px") {
          if (!laser_has_id) fail("<px> without <id_>");
          c.lasers.push_back(*laser);
          laser.reset();
        } else if (name == "distLSB_" && parent == "DB") {
          c.distance_resolution_m = number(pending_text, name) / 100.0;
          have_lsb = true;
        } else if (parent == "px" && laser) {
          assign(*laser, name, pending_text, laser_has_id);
        }
        stack_.pop_back();
      } else {
        const auto name = tag_name(1);
        if (name.empty()) fail("malformed tag");
        const auto gt = text_.find('>', pos_);
        if (gt == std::string_view::npos) fail("unterminated tag <" + std::string(name));
        const bool self_closing = text_[gt - 1] == '/';
        advance_to(gt + 1);
        if (!self_closing) {
          stack_.push_back(name);
          if (name == "px") {
            if (laser) fail("nested <px>");
            laser.emplace();
            laser_has_id = false;
          }
        }
      }
      text_start_ = pos_;
    }
    if (!stack_.empty()) fail("file ends inside <" + std::string(stack_.back()) + ">");
    if (c.lasers.empty()) fail("no <px> laser entries (not a VeloView calibration?)");
    if (!have_lsb) c.distance_resolution_m = 0.0;  // validation takes the model's
    return c;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw CalibrationError("calibration " + source_ + ":" + std::to_string(line_) + ": " + what);
  }
  bool starts_with(std::string_view s) const { return text_.substr(pos_, s.size()) == s; }
  void advance_to(std::size_t p) {
    for (std::size_t i = pos_; i < p && i < text_.size(); ++i) line_ += text_[i] == '\n' ? 1 : 0;
    pos_ = p;
  }
  void skip_past(std::string_view end) {
    const auto e = text_.find(end, pos_);
    if (e == std::string_view::npos) fail("unterminated markup");
    advance_to(e + end.size());
  }
  std::string_view tag_name(std::size_t skip) const {
    std::size_t i = pos_ + skip;
    const std::size_t start = i;
    while (i < text_.size()) {
      const char ch = text_[i];
      if (ch == ' ' || ch == '\t' || ch == '\n' || ch == '\r' || ch == '>' || ch == '/') break;
      ++i;
    }
    return text_.substr(start, i - start);
  }
  double number(std::string_view s, std::string_view field) const {
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\n' || s.front() == '\r'))
      s.remove_prefix(1);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\n' || s.back() == '\r'))
      s.remove_suffix(1);
    double v = 0.0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (s.empty() || ec != std::errc{} || end != s.data() + s.size() || !std::isfinite(v)) {
      std::string msg = "<";
      msg.append(field).append(">: expected a number, got '").append(s).append("'");
      fail(msg);
    }
    return v;
  }
  void assign(LaserCorrection& l, std::string_view name, std::string_view text, bool& has_id) const {
    if (name == "id_") {
      const double id = number(text, name);
      if (id < 0 || id > 127 || id != std::floor(id)) fail("<id_>: bad laser id '" + std::string(text) + "'");
      l.laser_id = static_cast<int>(id);
      has_id = true;
    } else if (name == "rotCorrection_") {
      l.rot_correction = number(text, name) * kRadPerDeg;
    } else if (name == "vertCorrection_") {
      l.vert_correction = number(text, name) * kRadPerDeg;
    } else if (name == "distCorrection_") {
      l.dist_correction = number(text, name) / 100.0;
    } else if (name == "distCorrectionX_") {
      l.dist_correction_x = number(text, name) / 100.0;
    } else if (name == "distCorrectionY_") {
      l.dist_correction_y = number(text, name) / 100.0;
    } else if (name == "vertOffsetCorrection_") {
      l.vert_offset_correction = number(text, name) / 100.0;
    } else if (name == "horizOffsetCorrection_") {
      l.horiz_offset_correction = number(text, name) / 100.0;
    } else if (name == "focalDistance_") {
      l.focal_distance = number(text, name) / 100.0;
    } else if (name == "focalSlope_") {
      l.focal_slope = number(text, name);
    }
  }

  std::string_view text_;
  const std::string& source_;
  std::size_t pos_ = 0;
  std::size_t text_start_ = 0;
  int line_ = 1;
  std::vector<std::string_view> stack_;
};

}  // namespace

Calibration parse_veloview_xml(std::string_view text, const std::string& source) {
  return XmlScanner(text, source).run();
}

}  // namespace sensor_rig::lidar::velodyne
