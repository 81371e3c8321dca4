// The test-domain lease (tests/support/dds_domain_lease.hpp): distinct domains within a process,
// a domain another process holds is never handed out, and it is free again once that process ends.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <set>

#include "dds_domain_lease.hpp"

namespace sensor_rig::test {
namespace {

TEST(DdsDomainLease, EachCallLeasesAnotherDomainInRange) {
  std::set<int> seen;
  for (int i = 0; i < 5; ++i) {
    const int d = lease_dds_domain();
    EXPECT_GE(d, kFirstLeasedDomain);
    EXPECT_LE(d, kLastLeasedDomain);
    EXPECT_TRUE(seen.insert(d).second) << "domain " << d << " leased twice";
  }
}

TEST(DdsDomainLease, AnotherProcesssLeaseIsRespectedAndFreedWhenItEnds) {
  int to_parent[2];
  int release[2];
  ASSERT_EQ(::pipe(to_parent), 0);
  ASSERT_EQ(::pipe(release), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const int d = DdsDomainLease::take().domain();  // temporary: must be given back at once
    auto kept = DdsDomainLease::try_take(d);
    const int k = kept.held() ? d : -1;
    (void)!::write(to_parent[1], &k, sizeof k);
    char c;
    (void)!::read(release[0], &c, 1);  // hold the lease until the parent has tried
    ::_exit(0);
  }
  int held = -1;
  ASSERT_EQ(::read(to_parent[0], &held, sizeof held), static_cast<ssize_t>(sizeof held));
  ASSERT_GE(held, kFirstLeasedDomain) << "a lease was not given back when its object ended";
  EXPECT_FALSE(DdsDomainLease::try_take(held).held()) << "domain " << held << " leased by two processes";
  (void)!::write(release[1], "x", 1);
  int st = 0;
  ASSERT_EQ(::waitpid(child, &st, 0), child);
  EXPECT_TRUE(DdsDomainLease::try_take(held).held()) << "the ended process's domain stayed taken";
  for (const int fd : {to_parent[0], to_parent[1], release[0], release[1]}) ::close(fd);
}

}  // namespace
}  // namespace sensor_rig::test
