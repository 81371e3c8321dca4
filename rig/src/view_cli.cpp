// `rig view [--port 8765] [--address 127.0.0.1] [--domain N]`: the rig live in Foxglove or Lichtblick
// (SPEC §7, docs/viewing.md). Prints one JSON stats line every --stats-interval seconds and at the
// end: clients, what each was sent and dropped, the DDS side's readers and losses.
#include <cstdio>
#include <exception>
#include <memory>
#include <nlohmann/json.hpp>
#include <system_error>

#include "rig_commands.hpp"
#include "sensor_rig/common/cli.hpp"
#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/log.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "view_bridge.hpp"

namespace sensor_rig::rig {
namespace {

nlohmann::json server_stats_json(const view::ServerStats& st) {
  nlohmann::json clients = nlohmann::json::array();
  for (const auto& c : st.clients) {
    nlohmann::json subs = nlohmann::json::array();
    for (const auto& s : c.subscriptions)
      subs.push_back({{"topic", s.topic}, {"sent", s.sent}, {"dropped", s.dropped}, {"queued", s.queued}});
    clients.push_back({{"id", c.id},
                       {"peer", c.peer},
                       {"messages_sent", c.messages_sent},
                       {"bytes_sent", c.bytes_sent},
                       {"dropped", c.dropped},
                       {"protocol_errors", c.protocol_errors},
                       {"subscriptions", subs}});
  }
  return {{"channels", st.channels},         {"clients_accepted", st.clients_accepted},
          {"clients_rejected", st.clients_rejected}, {"clients_closed", st.clients_closed},
          {"closed_overflow", st.closed_overflow},   {"published", st.published},
          {"dropped", st.dropped},           {"protocol_errors", st.protocol_errors},
          {"clients", clients}};
}

void print_stats(const view::Server& server, ViewBridge& bridge, bool final_line) {
  nlohmann::json j = server_stats_json(server.stats());
  j["dds"] = bridge.stats();
  j["t_ns"] = vehicle_now_ns();
  if (final_line) j["final"] = true;
  std::printf("%s\n", j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
  std::fflush(stdout);
}

}  // namespace

int run_view(const ViewOptions& options) {
  std::unique_ptr<view::Server> server;
  try {
    server = std::make_unique<view::Server>(options.server);
  } catch (const std::invalid_argument& e) {
    throw cli::UsageError(e.what());
  } catch (const std::system_error& e) {
    std::fprintf(stderr, "rig view: %s\n", e.what());
    return cli::kRuntime;
  }
  dds::Participant participant(options.dds);
  ViewBridge bridge(participant, *server, options.reader_depth);
  server->start(view::Server::Callbacks{[&bridge](view::ChannelId c) { bridge.request_reader(c, true); },
                                        [&bridge](view::ChannelId c) { bridge.request_reader(c, false); }});
  std::fprintf(stderr,
               "rig view: serving ws://%s:%u (domain %d) — in Foxglove or Lichtblick: Open connection -> "
               "Foxglove WebSocket -> ws://%s:%u\n",
               options.server.address.c_str(), server->port(), static_cast<int>(options.dds.domain_id),
               options.server.address.c_str(), server->port());
  const Nanos start = monotonic_now_ns();
  const Nanos interval = static_cast<Nanos>(options.stats_interval_s * 1e9);
  Nanos next_stats = start + interval;
  while (!shutdown_requested()) {
    const Nanos now = monotonic_now_ns();
    if (options.duration_s > 0 && now - start >= static_cast<Nanos>(options.duration_s * 1e9)) break;
    bridge.poll(100'000'000);
    if (interval > 0 && monotonic_now_ns() >= next_stats) {
      print_stats(*server, bridge, false);
      next_stats += interval;
    }
  }
  server->stop();
  print_stats(*server, bridge, true);
  return cli::kOk;
}

void register_view_cli(CLI::App& app, cli::Context& ctx) {
  auto* cmd = app.add_subcommand(
      "view", "Foxglove WebSocket server (foxglove.websocket.v1): the rig's topics live in Foxglove or Lichtblick");
  auto opt = std::make_shared<ViewOptions>();
  auto domain = std::make_shared<int>(0);
  auto profile = std::make_shared<std::string>();
  cmd->add_option("--port", opt->server.port, "TCP port (0: any free one, printed)")->capture_default_str();
  cmd->add_option("--address", opt->server.address,
                  "Address to listen on (loopback by default; 0.0.0.0 exposes the rig's data to the network)")
      ->capture_default_str();
  cmd->add_option("--domain", *domain, "DDS domain id")->check(CLI::Range(0, 232))->capture_default_str();
  cmd->add_option("--dds-profile", *profile, "Cyclone XML profile (default: loopback)");
  auto transport = std::make_shared<dds::Transport>(dds::Transport::kUdp);
  cmd->add_option("--transport", *transport, "udp, or shm: iceoryx shared memory (a RouDi must run, as `rig up` starts)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, dds::Transport>{{"udp", dds::Transport::kUdp},
                                                                                {"shm", dds::Transport::kShm}}));
  cmd->add_option("--duration", opt->duration_s, "Stop after S seconds (0: until Ctrl-C)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--queue", opt->server.queue.min_items,
                  "Messages kept per client and topic for a client that falls behind, more while they fit in 1 MiB "
                  "(the oldest are dropped)")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("--stats-interval", opt->stats_interval_s, "Seconds between JSON stats lines on stdout (0: at the end only)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->callback([&ctx, opt, domain, profile, transport] {
    opt->dds.domain_id = static_cast<dds_domainid_t>(*domain);
    opt->dds.profile = *profile;
    opt->dds.transport = *transport;
    ctx.exit_code = run_view(*opt);
  });
}

}  // namespace sensor_rig::rig
