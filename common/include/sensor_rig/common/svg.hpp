#pragma once
// Minimal self-contained SVG charts (no scripts, no external resources): `rig perf report` and
// `rig monitor --plot`. Each chart is one <svg> element; document() stacks charts into one file.
#include <string>
#include <vector>

namespace sensor_rig::svg {

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
// Points per series; `x_marks` (e.g. lost samples) as red ticks along the top edge, named `mark_name`.
std::string scatter(const std::string& title, const Axis& x, const Axis& y, const std::vector<Series>& series,
                    const std::vector<double>& x_marks = {}, const std::string& mark_name = "");
std::string boxes(const std::string& title, const Axis& y, const std::vector<Box>& b);
std::string stacks(const std::string& title, const std::vector<std::string>& part_names,
                   const std::vector<std::string>& colors, const std::vector<Stack>& rows);
std::string bars(const std::string& title, const Axis& y, const std::vector<std::string>& labels,
                 const std::vector<double>& values, const std::string& color);
// Charts one below the other in one standalone SVG document.
std::string document(const std::vector<std::string>& charts);

}  // namespace sensor_rig::svg
