#pragma once
// `rig perf report DIR`: DIR/report.html (self-contained SVG plots: latency over time as the paper's
// Fig. 8, box plots per size and subscriber count as Figs. 9-10, send/receive categories as Fig. 11,
// per-subscriber fairness as Fig. 14) and DIR/report.md (our figures beside the paper's).
// DIR is a run directory (summary.json) or any directory holding run directories (a table).
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace sensor_rig::bench::perf {

struct ReportResult {
  std::string html;      // path written
  std::string markdown;  // path written
  int runs = 0;
};

// What the paper reported for a configuration like this one (headline figures, for the table).
std::string paper_reference(const nlohmann::json& summary);
std::string markdown_table(const std::vector<nlohmann::json>& summaries);

ReportResult write_report(const std::string& dir);

}  // namespace sensor_rig::bench::perf
