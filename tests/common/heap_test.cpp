// keep_large_buffers(): a freed buffer of a cloud's size is reused, not faulted in anew.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <cstdlib>
#include <thread>

#include "sensor_rig/common/heap.hpp"

namespace sensor_rig {
namespace {

// ASan and TSan bring their own allocator (freed blocks wait in a quarantine; their mallopt does
// nothing): glibc's thresholds do not apply there.
constexpr bool sanitizer_allocator() {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  return true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
  return true;
#else
  return false;
#endif
#else
  return false;
#endif
}

long minor_faults_of_this_thread() {
  rusage r{};
  getrusage(RUSAGE_THREAD, &r);
  return r.ru_minflt;
}

// Buffers of a 1.2 MB cloud, each a page larger than the last (as scans grow): with glibc's
// defaults every one is a new mapping, ~300 page faults each.
long faults_for_growing_clouds(int clouds) {
  constexpr std::size_t kPage = 4096;
  const long before = minor_faults_of_this_thread();
  for (int i = 0; i < clouds; ++i) {
    const std::size_t size = 1'200'000 + static_cast<std::size_t>(i) * kPage;
    auto* p = static_cast<volatile char*>(std::malloc(size));
    if (p == nullptr) return -1;
    for (std::size_t k = 0; k < size; k += kPage) p[k] = 1;  // touch every page, as a copy would
    std::free(const_cast<char*>(p));
  }
  return minor_faults_of_this_thread() - before;
}

TEST(Heap, FreedCloudBuffersAreReused) {
  if (sanitizer_allocator()) GTEST_SKIP() << "the sanitizer's allocator, not glibc's";
  ASSERT_TRUE(keep_large_buffers());
  constexpr int kClouds = 40;
  long faults = 0;
  std::thread([&] { faults = faults_for_growing_clouds(kClouds); }).join();  // a thread, as Cyclone's
  // Reused: about one new page per cloud (it grew by one) instead of ~300 (measured: 333 vs 12,501).
  EXPECT_GE(faults, 0);
  EXPECT_LT(faults, kClouds * 30);
}

}  // namespace
}  // namespace sensor_rig
