// LoopbackAddress: what the rig adds to lo is removed when its last holder ends, also when a holder
// was killed; what the host had is never touched. Real addresses on the real lo (needs root or
// CAP_NET_ADMIN: skipped with the reason otherwise), a private registry (RIG_STATE_DIR), an address
// unique to this process.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "rig_process.hpp"
#include "sensor_rig/common/loopback_address.hpp"

namespace sensor_rig {
namespace {

class LoopbackAddressTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ::setenv("RIG_STATE_DIR", (state_.path / "state").c_str(), 1);
    // 127.1.x.y: far from the 127.0.0.x the camera tests use.
    const int p = static_cast<int>(::getpid());
    address_ = "127.1." + std::to_string(p / 250 % 250) + "." + std::to_string(1 + p % 250);
    ASSERT_FALSE(host_has_address(address_)) << address_ << " is on the host already";
    std::string why;
    auto probe = LoopbackAddress::take(address_, why);
    if (!probe) GTEST_SKIP() << why;
  }
  void TearDown() override { ::unsetenv("RIG_STATE_DIR"); }

  [[nodiscard]] std::string registry_text() const {
    std::ifstream in(LoopbackAddress::registry_path());
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

  test::TempDir state_;
  std::string address_;
};

TEST_F(LoopbackAddressTest, AnAddedAddressIsRemovedWithItsLeaseAndTheRegistryWithIt) {
  std::string why;
  {
    auto lease = LoopbackAddress::take(address_, why);
    ASSERT_TRUE(lease) << why;
    EXPECT_TRUE(lease->recorded());
    EXPECT_TRUE(host_has_address(address_));
    EXPECT_NE(registry_text().find(address_ + " " + std::to_string(::getpid()) + " "), std::string::npos)
        << registry_text();
  }
  EXPECT_FALSE(host_has_address(address_));
  EXPECT_FALSE(std::filesystem::exists(LoopbackAddress::registry_path()));
  EXPECT_FALSE(std::filesystem::exists(state_.path / "state")) << "the state folder is removed when empty";
}

TEST_F(LoopbackAddressTest, ASharedAddressStaysUntilItsLastHolderLetsGo) {
  std::string why;
  auto first = LoopbackAddress::take(address_, why);
  ASSERT_TRUE(first) << why;
  auto second = LoopbackAddress::take(address_, why);  // e.g. a test beside `rig up`
  ASSERT_TRUE(second) << why;
  EXPECT_TRUE(second->recorded()) << "an address the rig added is shared, not taken for the host's own";
  first.reset();
  EXPECT_TRUE(host_has_address(address_)) << "removed while a holder still used it";
  LoopbackAddress moved = std::move(*second);  // a moved lease is released once, by its new owner
  second.reset();
  EXPECT_TRUE(host_has_address(address_));
  moved = std::move(moved);
  EXPECT_TRUE(host_has_address(address_));
  {
    LoopbackAddress gone = std::move(moved);
  }
  EXPECT_FALSE(host_has_address(address_));
}

TEST_F(LoopbackAddressTest, TheHostsOwnAddressIsNeverRemoved) {
  std::string why;
  {
    auto lease = LoopbackAddress::take("127.0.0.1", why);
    ASSERT_TRUE(lease) << why;
    EXPECT_FALSE(lease->recorded());
  }
  EXPECT_TRUE(host_has_address("127.0.0.1"));
  EXPECT_FALSE(std::filesystem::exists(LoopbackAddress::registry_path()));
}

TEST_F(LoopbackAddressTest, AKilledHoldersAddressIsRemovedByTheNextSweepOrTake) {
  for (const bool by_take : {false, true}) {
    int ready[2];
    ASSERT_EQ(::pipe(ready), 0);
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      std::string why;
      auto lease = LoopbackAddress::take(address_, why);
      const char c = lease ? '1' : '0';
      (void)!::write(ready[1], &c, 1);
      ::pause();  // killed below, holding the lease
      ::_exit(0);
    }
    ::close(ready[1]);
    char c = 0;
    ASSERT_EQ(::read(ready[0], &c, 1), 1);
    ::close(ready[0]);
    ASSERT_EQ(c, '1');
    EXPECT_TRUE(host_has_address(address_));
    ::kill(child, SIGKILL);
    ::waitpid(child, nullptr, 0);
    EXPECT_TRUE(host_has_address(address_)) << "a SIGKILLed holder releases nothing by itself";
    if (by_take) {
      // The next holder finds the dead one's address recorded: it is the rig's, so it removes and
      // re-adds it and records itself; its release then removes it.
      std::string why;
      auto lease = LoopbackAddress::take(address_, why);
      ASSERT_TRUE(lease) << why;
      EXPECT_TRUE(lease->recorded());
      const std::string text = registry_text();
      EXPECT_EQ(text.rfind(address_ + " " + std::to_string(::getpid()) + " ", 0), 0u) << text;
      EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 1) << "the dead holder's line stays: " << text;
    } else {
      const auto removed = LoopbackAddress::sweep();
      ASSERT_EQ(removed.size(), 1u);
      EXPECT_EQ(removed[0], address_);
    }
    EXPECT_FALSE(host_has_address(address_));
  }
  EXPECT_FALSE(host_has_address(address_));
  EXPECT_FALSE(std::filesystem::exists(LoopbackAddress::registry_path()));
}

TEST(LoopbackAddress, RefusesWhatIsNoLoopbackAddressOrNoAddress) {
  std::string why;
  EXPECT_FALSE(LoopbackAddress::take("not-an-address", why));
  EXPECT_NE(why.find("not an IPv4 address"), std::string::npos) << why;
  EXPECT_FALSE(LoopbackAddress::take("192.0.2.77", why));  // TEST-NET-1: never on this host
  EXPECT_NE(why.find("only 127.0.0.0/8"), std::string::npos) << why;
}

}  // namespace
}  // namespace sensor_rig
