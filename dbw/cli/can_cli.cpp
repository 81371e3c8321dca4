// `rig can decode LOG --dbc FILE... [--signals MSG.SIG,...] --csv OUT` (SPEC §7).
#include <cstdio>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "dbw_commands.hpp"
#include "sensor_rig/common/cli.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "sensor_rig/dbw/can/log_decode.hpp"
#include "sensor_rig/dbw/can/transport.hpp"
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

struct ReplayOptions {
  std::string log;
  std::string transport;
  double rate = 1.0;
  bool loop = false;
};

// Sends every frame of the log to the transport at recorded timing (scaled by --rate).
int run_replay(const ReplayOptions& o) {
  std::unique_ptr<can::Transport> out;
  try {
    out = can::open_transport(o.transport);
  } catch (const can::TransportError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return cli::kUsage;
  }
  std::uint64_t sent = 0;
  std::uint64_t refused = 0;
  do {
    std::unique_ptr<can::Transport> src;
    try {
      src = can::open_transport("candump:" + o.log + "@" + std::to_string(o.rate));
    } catch (const can::TransportError& e) {
      std::fprintf(stderr, "error: %s\n", e.what());
      return cli::kUsage;
    }
    can::RxFrame rx;
    while (!shutdown_requested()) {
      const auto st = src->receive(rx, 100);
      if (st == can::IoStatus::kTimeout) continue;
      if (st != can::IoStatus::kOk) break;
      if (out->send(rx.frame) == can::IoStatus::kOk) {
        ++sent;
      } else {
        ++refused;
      }
    }
  } while (o.loop && !shutdown_requested());
  std::fprintf(stderr, "can replay: %llu frames sent, %llu refused\n", static_cast<unsigned long long>(sent),
               static_cast<unsigned long long>(refused));
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

  auto r = std::make_shared<ReplayOptions>();
  auto* rep = can.add_subcommand("replay", "send a candump -L log to a CAN transport at recorded timing");
  rep->add_option("log", r->log, "candump -L log file")->required();
  rep->add_option("--transport", r->transport, "socketcan:IFACE | unix:PATH | unix-listen:PATH | fd:N")->required();
  rep->add_option("--rate", r->rate, "speed factor (1 = recorded timing, 0 = as fast as possible)")
      ->check(CLI::NonNegativeNumber);
  rep->add_flag("--loop", r->loop, "start over at the end");
  rep->callback([r, &ctx] { ctx.exit_code = run_replay(*r); });
}

}  // namespace sensor_rig::dbw
