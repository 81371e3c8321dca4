// `rig can decode LOG --dbc FILE... [--signals MSG.SIG,...] --csv OUT` (SPEC §7).
#include <cstdio>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "dbw_commands.hpp"
#include "sensor_rig/dbw/can/log_decode.hpp"
#include "sensor_rig/dbw/dbc/parser.hpp"

namespace sensor_rig::dbw {
namespace {

struct DecodeOptions {
  std::string log;
  std::vector<std::string> dbc;
  std::vector<std::string> signals;
  std::string csv;
};

int run_decode(const DecodeOptions& o) {
  dbc::Database db;
  try {
    db = dbc::load_files(o.dbc);
  } catch (const dbc::DbcError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return cli::kUsage;
  }
  std::unique_ptr<can::LogDecoder> decoder;
  try {
    decoder = std::make_unique<can::LogDecoder>(db, o.signals);
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "error: --signals: %s\n", e.what());
    return cli::kUsage;
  }
  std::ifstream in(o.log);
  if (!in) {
    std::fprintf(stderr, "error: cannot open log %s\n", o.log.c_str());
    return cli::kUsage;
  }
  std::ofstream out(o.csv);
  if (!out) {
    std::fprintf(stderr, "error: cannot write %s\n", o.csv.c_str());
    return cli::kRuntime;
  }
  const auto st = decoder->to_csv(in, out);
  out.flush();
  if (!out) {
    std::fprintf(stderr, "error: writing %s failed\n", o.csv.c_str());
    return cli::kRuntime;
  }
  std::fprintf(stderr, "can decode: %llu frames, %llu decoded, %llu rows, %llu unknown ids, %llu short, %llu malformed lines\n",
               static_cast<unsigned long long>(st.frames), static_cast<unsigned long long>(st.decoded),
               static_cast<unsigned long long>(st.rows), static_cast<unsigned long long>(st.unknown),
               static_cast<unsigned long long>(st.short_frames), static_cast<unsigned long long>(st.malformed));
  return cli::kOk;
}

}  // namespace

void register_can_cli(CLI::App& can, cli::Context& ctx) {
  auto o = std::make_shared<DecodeOptions>();
  auto* dec = can.add_subcommand("decode", "candump -L log to CSV: t,iface,id,message,signal,value");
  dec->add_option("log", o->log, "candump -L log file")->required();
  dec->add_option("--dbc", o->dbc, "DBC file(s)")->required()->expected(1, -1);
  dec->add_option("--signals", o->signals, "MSG.SIG or MSG (all its signals), comma separated")->delimiter(',');
  dec->add_option("--csv", o->csv, "output CSV")->required();
  dec->callback([o, &ctx] { ctx.exit_code = run_decode(*o); });
}

}  // namespace sensor_rig::dbw
