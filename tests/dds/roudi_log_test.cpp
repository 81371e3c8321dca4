// RouDi's log path: readiness is read from the log, so RouDi replaces it before starting, and only
// a regular file may be replaced. (A log path of /dev/null once removed the device when run as root.)
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <stdexcept>
#include <string>

#include "sensor_rig/dds/roudi.hpp"

namespace sensor_rig::dds {
namespace {

TEST(RoudiLog, ANonRegularLogPathIsRefusedAndLeftAlone) {
  if (probe_roudi().pid != 0) GTEST_SKIP() << "a RouDi runs on this machine: the constructor would join it";
  char dir[] = "/tmp/rig-roudi-log-XXXXXX";
  ASSERT_NE(::mkdtemp(dir), nullptr);
  const std::string fifo = std::string(dir) + "/log.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    RouDi roudi("", fifo, false);
    ADD_FAILURE() << "a FIFO was accepted as the RouDi log";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(std::filesystem::is_fifo(fifo)) << "the FIFO is still there";
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace sensor_rig::dds
