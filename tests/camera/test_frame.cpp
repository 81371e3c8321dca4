#include <gtest/gtest.h>

#include "sensor_rig/camera/frame.hpp"

namespace sensor_rig::camera {
namespace {

TEST(BufferPool, IsBoundedAndReusesTheSameMemory) {
  BufferPool pool(3, 1024);
  std::vector<std::size_t> taken;
  std::vector<const std::uint8_t*> addrs;
  for (int i = 0; i < 3; ++i) {
    auto idx = pool.acquire();
    ASSERT_TRUE(idx.has_value());
    taken.push_back(*idx);
    addrs.push_back(pool.buffer(*idx).data());
    EXPECT_EQ(pool.buffer(*idx).size(), 1024u);
  }
  EXPECT_FALSE(pool.acquire().has_value());  // an underrun, not an allocation
  EXPECT_EQ(pool.available(), 0u);
  pool.release(taken[1]);
  const auto again = pool.acquire();
  ASSERT_TRUE(again.has_value());
  EXPECT_EQ(pool.buffer(*again).data(), addrs[1]);
  EXPECT_TRUE(pool.buffer(99).empty());
  EXPECT_THROW(BufferPool(0, 10), std::invalid_argument);
}

TEST(Frame, ReturnsItsBufferExactlyOnceWhenDropped) {
  BufferPool pool(1, 64);
  const auto idx = pool.acquire();
  ASSERT_TRUE(idx);
  int released = 0;
  {
    Frame f(FrameMeta{}, pool.buffer(*idx), [&] {
      ++released;
      pool.release(*idx);
    });
    EXPECT_EQ(f.data().data(), pool.buffer(*idx).data());  // the pool memory itself: no copy
    Frame moved = std::move(f);
    EXPECT_TRUE(f.empty());  // NOLINT(bugprone-use-after-move): moved-from is empty by contract
    EXPECT_EQ(released, 0);
    EXPECT_EQ(pool.available(), 0u);
  }
  EXPECT_EQ(released, 1);
  EXPECT_EQ(pool.available(), 1u);
}

}  // namespace
}  // namespace sensor_rig::camera
