// `rig chaos CONFIG --duration S --seed N [--faults SPEC] [--rate PER_MIN] [--json] [--out DIR]`, and
// `rig chaos --judge DIR [--json]` (docs/faults.md).
#include <memory>
#include <string>

#include "chaos_run.hpp"
#include "sensor_rig/common/cli.hpp"
#include "rig_commands.hpp"
#include "sensor_rig/common/fault_plan.hpp"

namespace sensor_rig::rig {
namespace {

std::string kinds_help() {
  std::string out = "Fault kinds the mocks inject (KIND[:NAME=VALUE]...[@START_S][+DURATION_S][~EVERY_S][>DEVICE]):\n";
  for (const auto& kind : chaos::injected_kinds()) {
    const auto* k = faults::find_kind(kind);
    if (k == nullptr) continue;
    out += "  " + std::string(k->name) + (k->params.empty() ? "" : " (" + std::string(k->params) + ")") + ": " +
           std::string(k->what) + (k->draws.empty() ? "" : " [random: " + std::string(k->draws) + "]") + "\n";
  }
  out += "A random fault draws its parameters and duration from the kind's [random: ...] ranges (docs/faults.md), "
         "with --default-params it takes the defaults in (...).\n";
  return out;
}

}  // namespace

void register_chaos_cli(CLI::App& app, cli::Context& ctx) {
  auto o = std::make_shared<chaos::Options>();
  auto* cmd = app.add_subcommand("chaos", "The rig on its mocks under a fault campaign, its output checked against the mocks' truth");
  cmd->footer(kinds_help());
  cmd->add_option("CONFIG", o->config, "Rig config (YAML) whose devices all have mocks (required unless --judge)");
  cmd->add_option("--duration", o->duration_s, "Seconds of faults (after a warm-up)")->check(CLI::Range(5.0, 86400.0))->capture_default_str();
  cmd->add_option("--seed", o->seed, "Seed of the random plan: same seed, same campaign")->capture_default_str();
  cmd->add_option("--faults", o->faults,
                  "Fault specs, ';'-separated or repeated: with @START a fault at that time, without a kind placed at random "
                  "(default: every kind the mocks inject; 'none': a baseline without faults)");
  cmd->add_option("--rate", o->rate_per_min, "Random faults per minute (on top of one of each kind)")->check(CLI::NonNegativeNumber)->capture_default_str();
  cmd->add_flag("--default-params", o->default_params,
                "Random faults take each kind's default parameters and duration, not draws from its ranges (the plans "
                "of seeds before 2026-12-01)");
  cmd->add_flag("--json", o->json, "Last line on stdout: {\"faults\":..,\"topics\":..,\"invariants\":..}");
  cmd->add_option("--out", o->out_dir, "Keep the campaign here: plan.jsonl, truth/*.jsonl, monitor.csv, fused_sets.jsonl, judge.json, logs/");
  cmd->add_option("--judge", o->judge_dir,
                  "Judge a campaign kept with --out again (after a fix of the judge, or to read a verdict a test printed): runs nothing")
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--warmup", o->warmup_s, "Seconds for the rig to start before the first fault")->check(CLI::Range(1.0, 60.0))->capture_default_str();
  cmd->callback([o, &ctx] { ctx.exit_code = chaos::run(*o); });
}

}  // namespace sensor_rig::rig
