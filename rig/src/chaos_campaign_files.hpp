#pragma once
// A campaign as `rig chaos --out DIR` keeps it: plan.jsonl, truth/*.jsonl, monitor.csv,
// fused_sets.jsonl and judge.json (the rest of the judge's input: the window, the monitor's totals,
// the rig's counts and flags, what the config expects). `rig chaos --judge DIR` reads it back and
// judges it again without running anything: after a fix of the judge, or to read a verdict that a
// test printed (docs/faults.md "Judging a kept campaign again").
#include <filesystem>
#include <string>
#include <vector>

#include "chaos_check.hpp"

namespace sensor_rig::rig::chaos {

// Every mock's truth record in `dir` (its *.jsonl, in name order). Throws std::runtime_error naming
// the file and line of a bad record.
std::vector<truth::Log> read_truths(const std::filesystem::path& dir);

// The fused sweeps' members as received, one JSON line per sweep.
void write_fused_sets(const std::string& path, const std::vector<FusedSet>& sets);
std::vector<FusedSet> read_fused_sets(const std::string& path);  // throws std::runtime_error (file:line)

// judge.json: the parts of `in` no other file of the campaign holds, and the campaign's errors.
void write_judge_input(const std::string& path, const Input& in, const std::vector<std::string>& campaign_errors);

// The whole input from a kept campaign (its bounds: today's defaults). Throws std::runtime_error
// naming what is missing or bad.
Input read_campaign(const std::filesystem::path& dir, std::vector<std::string>& campaign_errors);

}  // namespace sensor_rig::rig::chaos
