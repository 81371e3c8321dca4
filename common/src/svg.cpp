#include "sensor_rig/common/svg.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace sensor_rig::svg {
namespace {
constexpr double kW = 860, kH = 300, kL = 70, kR = 20, kT = 30, kB = 60;

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", v);
  return b;
}
std::string tick_label(double v) {
  char b[32];
  if (v != 0 && (std::fabs(v) < 0.01 || std::fabs(v) >= 10000)) std::snprintf(b, sizeof b, "%.0e", v);
  else std::snprintf(b, sizeof b, "%g", v);
  return b;
}

struct Map {
  Axis a;
  double p0, p1;  // pixel range
  double operator()(double v) const {
    double lo = a.lo, hi = a.hi;
    if (a.log) {
      v = std::log10(std::max(v, a.lo));
      lo = std::log10(a.lo);
      hi = std::log10(a.hi);
    }
    if (hi <= lo) hi = lo + 1;
    const double f = std::clamp((v - lo) / (hi - lo), 0.0, 1.0);
    return p0 + (p1 - p0) * f;
  }
  std::vector<double> ticks() const {
    std::vector<double> t;
    if (a.log) {
      for (double d = std::pow(10.0, std::floor(std::log10(a.lo))); d <= a.hi * 1.0001; d *= 10) {
        if (d >= a.lo * 0.9999) t.push_back(d);
      }
    } else {
      const double span = a.hi - a.lo;
      const double raw = span / 5;
      const double mag = std::pow(10.0, std::floor(std::log10(raw > 0 ? raw : 1)));
      double step = mag;
      for (double m : {1.0, 2.0, 5.0, 10.0}) {
        if (mag * m >= raw) {
          step = mag * m;
          break;
        }
      }
      for (double v = std::ceil(a.lo / step) * step; v <= a.hi + step * 1e-9; v += step) t.push_back(v);
    }
    return t;
  }
};

void frame(std::ostringstream& o, const std::string& title, const Map* x, const Map& y) {
  o << "<svg xmlns='http://www.w3.org/2000/svg' width='" << kW << "' height='" << kH << "' font-family='sans-serif' font-size='11'>";
  o << "<text x='" << kW / 2 << "' y='16' text-anchor='middle' font-size='13' font-weight='bold'>" << escape(title) << "</text>";
  o << "<rect x='" << kL << "' y='" << kT << "' width='" << kW - kL - kR << "' height='" << kH - kT - kB
    << "' fill='none' stroke='#888'/>";
  for (double t : y.ticks()) {
    o << "<line x1='" << kL << "' x2='" << kW - kR << "' y1='" << num(y(t)) << "' y2='" << num(y(t)) << "' stroke='#eee'/>";
    o << "<text x='" << kL - 4 << "' y='" << num(y(t) + 4) << "' text-anchor='end'>" << tick_label(t) << "</text>";
  }
  o << "<text transform='translate(14," << (kT + kH - kB) / 2 << ") rotate(-90)' text-anchor='middle'>" << escape(y.a.label) << "</text>";
  if (x != nullptr) {
    for (double t : x->ticks()) {
      o << "<text x='" << num((*x)(t)) << "' y='" << kH - kB + 14 << "' text-anchor='middle'>" << tick_label(t) << "</text>";
    }
    o << "<text x='" << (kL + kW - kR) / 2 << "' y='" << kH - kB + 30 << "' text-anchor='middle'>" << escape(x->a.label) << "</text>";
  }
}
}  // namespace

std::string escape(const std::string& s) {
  std::string r;
  for (char c : s) {
    switch (c) {
      case '<': r += "&lt;"; break;
      case '>': r += "&gt;"; break;
      case '&': r += "&amp;"; break;
      case '\'': r += "&#39;"; break;
      case '"': r += "&quot;"; break;
      default: r += c;
    }
  }
  return r;
}

std::string scatter(const std::string& title, const Axis& xa, const Axis& ya, const std::vector<Series>& series,
                    const std::vector<double>& x_marks, const std::string& mark_name) {
  std::ostringstream o;
  const Map x{xa, kL, kW - kR}, y{ya, kH - kB, kT};
  frame(o, title, &x, y);
  double lx = kL + 10;
  for (const auto& s : series) {
    o << "<g class='series' fill='" << s.color << "' fill-opacity='0.6'>";
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      o << "<circle cx='" << num(x(s.x[i])) << "' cy='" << num(y(s.y[i])) << "' r='1.4'/>";
    }
    o << "</g><rect x='" << num(lx) << "' y='" << kH - 18 << "' width='10' height='10' fill='" << s.color << "'/>"
      << "<text x='" << num(lx + 14) << "' y='" << kH - 9 << "'>" << escape(s.name) << "</text>";
    lx += 24 + 6.5 * static_cast<double>(s.name.size());
  }
  if (!x_marks.empty()) {
    constexpr const char* kMarkColor = "#d62728";
    o << "<g class='marks' stroke='" << kMarkColor << "' stroke-width='1.5'>";
    for (double v : x_marks)
      o << "<line x1='" << num(x(v)) << "' x2='" << num(x(v)) << "' y1='" << kT << "' y2='" << kT + 8 << "'/>";
    o << "</g><line x1='" << num(lx) << "' x2='" << num(lx) << "' y1='" << kH - 18 << "' y2='" << kH - 8
      << "' stroke='" << kMarkColor << "' stroke-width='1.5'/><text x='" << num(lx + 5) << "' y='" << kH - 9 << "'>"
      << escape(mark_name) << " (" << x_marks.size() << ")</text>";
  }
  o << "</svg>";
  return o.str();
}

std::string boxes(const std::string& title, const Axis& ya, const std::vector<Box>& b) {
  std::ostringstream o;
  const Map y{ya, kH - kB, kT};
  frame(o, title, nullptr, y);
  const double slot = (kW - kL - kR) / static_cast<double>(std::max<std::size_t>(1, b.size()));
  for (std::size_t i = 0; i < b.size(); ++i) {
    const double cx = kL + slot * (static_cast<double>(i) + 0.5);
    const double w = std::min(30.0, slot * 0.6);
    const auto& v = b[i];
    o << "<line x1='" << num(cx) << "' x2='" << num(cx) << "' y1='" << num(y(v.p1)) << "' y2='" << num(y(v.p99)) << "' stroke='#333'/>";
    o << "<rect x='" << num(cx - w / 2) << "' y='" << num(y(v.p75)) << "' width='" << num(w) << "' height='"
      << num(std::max(1.0, y(v.p25) - y(v.p75))) << "' fill='#9cc3e6' stroke='#333' class='box'/>";
    o << "<line x1='" << num(cx - w / 2) << "' x2='" << num(cx + w / 2) << "' y1='" << num(y(v.p50)) << "' y2='" << num(y(v.p50))
      << "' stroke='#c00' stroke-width='2'/>";
    o << "<circle cx='" << num(cx) << "' cy='" << num(y(v.max)) << "' r='2' fill='none' stroke='#333'/>";
    o << "<text transform='translate(" << num(cx + 3) << "," << kH - kB + 6 << ") rotate(40)' font-size='9'>" << escape(v.label) << "</text>";
  }
  o << "</svg>";
  return o.str();
}

std::string stacks(const std::string& title, const std::vector<std::string>& names, const std::vector<std::string>& colors,
                   const std::vector<Stack>& rows) {
  std::ostringstream o;
  const double row_h = 16, top = 40, left = 260, width = kW - left - 20;
  const double h = top + row_h * static_cast<double>(rows.size()) + 30;
  o << "<svg xmlns='http://www.w3.org/2000/svg' width='" << kW << "' height='" << num(h) << "' font-family='sans-serif' font-size='10'>";
  o << "<text x='" << kW / 2 << "' y='14' text-anchor='middle' font-size='13' font-weight='bold'>" << escape(title) << "</text>";
  double lx = left;
  for (std::size_t k = 0; k < names.size(); ++k) {
    o << "<rect x='" << num(lx) << "' y='22' width='10' height='10' fill='" << colors[k % colors.size()] << "'/><text x='"
      << num(lx + 13) << "' y='31'>" << escape(names[k]) << "</text>";
    lx += 30 + 6.0 * static_cast<double>(names[k].size());
  }
  for (std::size_t r = 0; r < rows.size(); ++r) {
    const double y = top + row_h * static_cast<double>(r);
    o << "<text x='" << left - 4 << "' y='" << num(y + 11) << "' text-anchor='end'>" << escape(rows[r].label) << "</text>";
    double x = left;
    for (std::size_t k = 0; k < rows[r].parts.size(); ++k) {
      const double w = width * std::clamp(rows[r].parts[k], 0.0, 1.0);
      if (w > 0) o << "<rect x='" << num(x) << "' y='" << num(y) << "' width='" << num(w) << "' height='" << row_h - 3
                   << "' fill='" << colors[k % colors.size()] << "'/>";
      x += w;
    }
  }
  o << "</svg>";
  return o.str();
}

std::string bars(const std::string& title, const Axis& ya, const std::vector<std::string>& labels,
                 const std::vector<double>& values, const std::string& color) {
  std::ostringstream o;
  const Map y{ya, kH - kB, kT};
  frame(o, title, nullptr, y);
  const double slot = (kW - kL - kR) / static_cast<double>(std::max<std::size_t>(1, values.size()));
  for (std::size_t i = 0; i < values.size(); ++i) {
    const double x = kL + slot * static_cast<double>(i);
    const double top = y(values[i]);
    o << "<rect x='" << num(x + slot * 0.15) << "' y='" << num(top) << "' width='" << num(slot * 0.7) << "' height='"
      << num(kH - kB - top) << "' fill='" << color << "'/>";
    if (i < labels.size() && (values.size() <= 40 || i % 4 == 0)) {
      o << "<text x='" << num(x + slot / 2) << "' y='" << kH - kB + 12 << "' text-anchor='middle' font-size='9'>" << escape(labels[i]) << "</text>";
    }
  }
  o << "</svg>";
  return o.str();
}

std::string document(const std::vector<std::string>& charts) {
  // Each chart is one of ours: "<svg ... height='H' ...>"; nested at its offset.
  std::ostringstream o;
  double top = 0;
  std::ostringstream body;
  for (const auto& c : charts) {
    double h = kH;
    if (const auto at = c.find("height='"); at != std::string::npos) h = std::atof(c.c_str() + at + 8);
    body << "<svg y='" << num(top) << "'" << c.substr(4);
    top += h + 10;
  }
  o << "<?xml version='1.0' encoding='UTF-8'?>\n<svg xmlns='http://www.w3.org/2000/svg' width='" << kW
    << "' height='" << num(std::max(top, 1.0)) << "'><rect width='100%' height='100%' fill='white'/>" << body.str()
    << "</svg>\n";
  return o.str();
}

}  // namespace sensor_rig::svg
