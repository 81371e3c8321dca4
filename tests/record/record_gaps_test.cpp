// rig/src/record_gaps.hpp: how `rig record` counts samples the rig announced on /rig/stamps and it
// never received. SourceStamps and stamped messages as XCDR1 bytes built here, in both byte orders;
// the bookkeeping in either order of arrival, the timeout, truncated bytes. The recorder against
// real DDS: tests/record/record_monitor_counts_test.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <vector>

#include "../../rig/src/record_gaps.hpp"

namespace sensor_rig::rig {
namespace {

// XCDR1 writer: primitives aligned to their size from the body's start.
class Cdr {
 public:
  explicit Cdr(std::endian order) : order_(order) {
    bytes_ = {std::byte{0}, order == std::endian::little ? std::byte{1} : std::byte{0}, std::byte{0}, std::byte{0}};
  }
  template <class T>
  Cdr& put(T v) {
    while ((bytes_.size() - 4) % sizeof(T) != 0) bytes_.push_back(std::byte{0});
    std::byte b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (order_ != std::endian::native) std::reverse(b, b + sizeof(T));
    bytes_.insert(bytes_.end(), b, b + sizeof(T));
    return *this;
  }
  Cdr& str(const std::string& s) {
    put<std::uint32_t>(static_cast<std::uint32_t>(s.size() + 1));
    for (const char c : s) bytes_.push_back(static_cast<std::byte>(c));
    bytes_.push_back(std::byte{0});
    return *this;
  }
  [[nodiscard]] std::span<const std::byte> all() const { return bytes_; }
  [[nodiscard]] std::span<const std::byte> body() const { return all().subspan(4); }

 private:
  std::endian order_;
  std::vector<std::byte> bytes_;
};

Cdr stamps(std::endian order, std::int32_t sec, std::uint32_t nsec, const std::string& frame, const std::string& topic,
           std::int64_t publish_ns) {
  Cdr c(order);
  c.put(sec).put(nsec).str(frame).str(topic).put<std::uint64_t>(7);
  for (std::int64_t v : {1LL, 2LL, 3LL, 4LL}) c.put<std::int64_t>(v);  // acquisition .. ready
  c.put<std::int64_t>(publish_ns).put<std::int64_t>(publish_ns + 5);   // publish, written
  for (std::uint32_t v : {1u, 2u, 3u, 4u}) c.put(v);
  c.put<std::int64_t>(0);
  return c;
}

TEST(RecordGaps, SourceStampsParseInBothByteOrders) {
  // frame ids of lengths that put the topic string and the int64s at each alignment
  for (const auto order : {std::endian::little, std::endian::big}) {
    for (const std::string frame : {"", "a", "ab", "abc", "lidar_front"}) {
      SCOPED_TRACE(frame);
      const Cdr c = stamps(order, 1'700'000'000, 123'456'789, frame, "/sensors/lidar/front/points", 42'000'000'000);
      ASSERT_EQ(record_cdr::order_of(c.all()), order);
      const auto a = record_cdr::source_stamps(c.body(), order);
      ASSERT_TRUE(a.has_value());
      EXPECT_EQ(a->stamp, 1'700'000'000'123'456'789);
      EXPECT_EQ(a->topic, "/sensors/lidar/front/points");
      EXPECT_EQ(a->publish_ns, 42'000'000'000);
      // Cut anywhere before publish_ns's end (written, 4 uint32, ecu_status_ns follow: 32 bytes): no
      // value, no read past the end; what follows it is not needed.
      const std::size_t publish_end = c.body().size() - 32;
      for (std::size_t n = 0; n < publish_end; ++n)
        EXPECT_FALSE(record_cdr::source_stamps(c.body().first(n), order).has_value()) << n;
      EXPECT_TRUE(record_cdr::source_stamps(c.body().first(publish_end), order).has_value());
    }
  }
  const std::byte bad[] = {std::byte{0}, std::byte{3}, std::byte{0}, std::byte{0}};  // PL_CDR: not ours
  EXPECT_FALSE(record_cdr::order_of(bad).has_value());
}

TEST(RecordGaps, AHeaderStampIsTheFirstEightBytes) {
  Cdr c(std::endian::big);
  c.put<std::int32_t>(12).put<std::uint32_t>(34).str("frame");
  EXPECT_EQ(record_cdr::header_stamp(c.body(), std::endian::big), 12'000'000'034);
  EXPECT_FALSE(record_cdr::header_stamp(c.body().first(7), std::endian::big).has_value());
}

TEST(RecordGaps, AnnouncedAndNotReceivedWithinTheTimeoutIsMissedOnce) {
  constexpr Nanos kS = 1'000'000'000;
  AnnouncedSamples a;
  std::map<std::string, int> missed;
  const auto count = [&](const std::string& t) { ++missed[t]; };
  a.on_data("/a", 100, 0);         // data first
  a.on_announced("/a", 100, 1);    // then its stamps: matched
  a.on_announced("/a", 200, 2);    // stamps first
  a.on_data("/a", 200, 3);         // then its data: matched
  a.on_announced("/a", 300, 4);    // never comes
  a.on_announced("/b", 300, 4);    // another topic, same stamp: never comes either
  a.on_data("/b", 400, 5);         // data never announced: not a loss
  a.expire(kS, kS, count);         // not yet a timeout old
  EXPECT_TRUE(missed.empty());
  a.expire(kS + 5, kS, count);
  EXPECT_EQ(missed["/a"], 1);
  EXPECT_EQ(missed["/b"], 1);
  a.expire(10 * kS, kS, count);    // counted once
  EXPECT_EQ(missed["/a"], 1);
  EXPECT_EQ(missed["/b"], 1);
  // Received data is forgotten after 5 timeouts: its stamps coming later still are a loss
  // (bounded memory; 5 s late is lost for the monitor too).
  a.on_data("/c", 500, 10 * kS);
  a.expire(16 * kS, kS, count);
  a.on_announced("/c", 500, 16 * kS);
  a.expire(18 * kS, kS, count);
  EXPECT_EQ(missed["/c"], 1);
}

}  // namespace
}  // namespace sensor_rig::rig
