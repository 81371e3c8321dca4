// Temporary: the dbw and mock command groups land with the safety core and the mock ECU.
#include "dbw_commands.hpp"

namespace sensor_rig::dbw {
void register_dbw_cli(CLI::App& /*dbw*/, cli::Context& /*ctx*/) {}
}  // namespace sensor_rig::dbw
