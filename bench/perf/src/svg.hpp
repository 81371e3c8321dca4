#pragma once
// Minimal self-contained SVG charts for the perf report (no scripts, no external resources).
#include <string>
#include <vector>

namespace sensor_rig::bench::perf::svg {

struct Axis {
  double lo = 0, hi = 1;
  bool log = false;
  std::string label;
};

struct Series {
  std::string name;
  std::string color;
  std::vector<double> x, y;
};

struct Box {
  std::string label;
  double p1 = 0, p25 = 0, p50 = 0, p75 = 0, p99 = 0, max = 0, mean = 0;
};

struct Stack {
  std::string label;
  std::vector<double> parts;  // fractions in [0, 1], drawn left to right
};

std::string escape(const std::string& s);
std::string scatter(const std::string& title, const Axis& x, const Axis& y, const std::vector<Series>& series);
std::string boxes(const std::string& title, const Axis& y, const std::vector<Box>& b);
std::string stacks(const std::string& title, const std::vector<std::string>& part_names,
                   const std::vector<std::string>& colors, const std::vector<Stack>& rows);
std::string bars(const std::string& title, const Axis& y, const std::vector<std::string>& labels,
                 const std::vector<double>& values, const std::string& color);

}  // namespace sensor_rig::bench::perf::svg
