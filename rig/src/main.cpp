// `rig`: one command for every sensor-rig tool. Each area registers its subcommands here.
#include <cstdio>
#include <exception>

#include "sensor_rig/common/cli.hpp"
#include "sensor_rig/common/errors.hpp"
#include "sensor_rig/common/heap.hpp"
#include "sensor_rig/common/shutdown.hpp"
#include "rig_commands.hpp"

namespace {

int run(int argc, char** argv) {
  CLI::App app{"sensor-rig: drivers, mocks and measurements for an automated car's perception unit", "rig"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "sensor-rig 0.1.0");
  sensor_rig::cli::Context ctx;
  sensor_rig::register_all_commands(app, ctx);
  sensor_rig::install_shutdown_handlers();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : sensor_rig::cli::kUsage;
  } catch (const sensor_rig::ConfigError& e) {
    std::fprintf(stderr, "config error:\n%s", e.what());
    return sensor_rig::cli::kUsage;
  } catch (const sensor_rig::cli::UsageError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return sensor_rig::cli::kUsage;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return sensor_rig::cli::kRuntime;
  }
  return ctx.exit_code;
}

}  // namespace

int main(int argc, char** argv) {
  // Every subcommand that publishes or subscribes clouds and images reuses its sample buffers.
  (void)sensor_rig::keep_large_buffers();
  try {
    return run(argc, argv);
  } catch (...) {  // building the command tree failed (out of memory): nothing else to say
    std::fputs("error: rig could not start\n", stderr);
    return sensor_rig::cli::kRuntime;
  }
}
