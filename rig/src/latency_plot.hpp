#pragma once
// The latency plot of a monitor recording (`rig monitor --plot`, `rig report --plot`): per topic,
// each stage's latency over time with lost samples marked, and one box per stage.
#include <string>
#include <vector>

#include "sample_record.hpp"

namespace sensor_rig::rig {

// One standalone SVG document; topics in name order, stages in kStageNames order (those with data).
std::string latency_plot_svg(const std::vector<SampleRecord>& records);

// Writes latency_plot_svg(records) to `path`; throws std::runtime_error when it cannot.
void write_latency_plot(const std::string& path, const std::vector<SampleRecord>& records);

}  // namespace sensor_rig::rig
