// rig/src/record_gaps.hpp: how `rig record` counts samples the rig announced on /rig/stamps and it
// never received. SourceStamps and stamped messages as XCDR1 bytes built here, in both byte orders;
// the bookkeeping in either order of arrival, the timeout, truncated bytes, seq gaps (announcements
// lost too), a model of a rig whose recorder stops for seconds (against the truth of what it
// published), the memory bounds. The recorder against real DDS: tests/record/record_monitor_counts_test.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <deque>
#include <iostream>
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

// A sample announced with its seq and received, both at `now`.
void delivered(AnnouncedSamples& a, const std::string& topic, Nanos stamp, std::uint64_t seq, Nanos now) {
  a.on_announced(topic, stamp, seq, now);
  a.on_data(topic, stamp, now);
}

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
  const auto missed = [&](const std::string& t) { return a.counts(t).missed; };
  a.on_data("/a", 100, 0);            // data first
  a.on_announced("/a", 100, 1, 1);    // then its stamps: matched
  a.on_announced("/a", 200, 2, 2);    // stamps first
  a.on_data("/a", 200, 3);            // then its data: matched
  a.on_announced("/a", 300, 3, 4);    // never comes
  a.on_announced("/b", 300, 3, 4);    // another topic, same stamp: never comes either
  a.expire(kS, kS);                   // not yet a timeout old, no later sample
  EXPECT_EQ(missed("/a"), 0u);
  EXPECT_EQ(missed("/b"), 0u);
  a.on_data("/b", 400, 5);            // a later sample (never announced: not a loss itself)
  a.expire(kS, kS);                   // 300's can no longer come: samples arrive in order
  EXPECT_EQ(missed("/a"), 0u);
  EXPECT_EQ(missed("/b"), 1u);
  a.expire(kS + 5, kS);               // a timeout old
  EXPECT_EQ(missed("/a"), 1u);
  EXPECT_EQ(missed("/b"), 1u);
  a.expire(10 * kS, kS);              // counted once
  EXPECT_EQ(missed("/a"), 1u);
  EXPECT_EQ(missed("/b"), 1u);
  // Received data is forgotten after 5 timeouts: its stamps coming later still are a loss
  // (bounded memory; 5 s late is lost for the monitor too).
  a.on_data("/c", 500, 10 * kS);
  a.expire(16 * kS, kS);
  a.on_announced("/c", 500, 0, 16 * kS);
  a.expire(18 * kS, kS);
  EXPECT_EQ(missed("/c"), 1u);
  EXPECT_EQ(a.counts("/a").overflow + a.counts("/b").overflow + a.counts("/c").overflow, 0u);
}

// A gap in a topic's seq: samples whose announcements were lost too. Those received (their stamp
// inside the gap, matched nothing) are not missed; the rest are, once a later sample came (none of
// the gap's can come after it) or the timeout passed. A seq that goes back starts over (but for a
// GigE frame id's wrap); announcements before the count started only set where the seq stands.
TEST(RecordGaps, ASeqGapIsMissedButForWhatWasReceivedInIt) {
  constexpr Nanos kS = 1'000'000'000;
  AnnouncedSamples a;
  a.on_announced("/l", 10, 5, 0, /*counted=*/false);  // before the count: no gap before it
  a.on_data("/l", 10, 0);
  delivered(a, "/l", 20, 6, 0);
  a.on_data("/l", 50, 1);                // seq 9's sample, its stamps lost
  a.on_announced("/l", 100, 14, 2);      // seqs 7..13 announced and lost: a gap of 7
  a.on_data("/l", 70, 3);                // seq 11's sample, after the announcement after it
  a.expire(kS, kS);
  EXPECT_EQ(a.counts("/l").missed, 0u);  // no later sample yet: seq 13's may be on the way
  a.on_data("/l", 90, 2 * kS);           // seq 13's, 2 s late (a repair): still counted received
  a.expire(2 * kS, 5 * kS);
  EXPECT_EQ(a.counts("/l").missed, 0u);
  a.on_data("/l", 100, 2 * kS);          // seq 14's: the gap is passed
  a.expire(2 * kS, 5 * kS);
  EXPECT_EQ(a.counts("/l").missed, 4u);  // 7 - 3 received
  a.on_data("/l", 80, 3 * kS);           // out of order: cannot happen, and changes nothing
  a.expire(10 * kS, kS);
  EXPECT_EQ(a.counts("/l").missed, 4u);
  // A topic that goes quiet: its gap is decided after the timeout.
  delivered(a, "/q", 10, 1, 0);
  a.on_announced("/q", 40, 4, 0);        // 2 and 3 lost with their stamps, and 4's sample never comes
  a.expire(kS, kS);
  EXPECT_EQ(a.counts("/q").missed, 0u);
  a.expire(kS + 1, kS);
  EXPECT_EQ(a.counts("/q").missed, 3u);
  a.on_announced("/l", 200, 0, 11 * kS);  // the driver restarted: seq 0 again, no gap
  a.on_data("/l", 200, 11 * kS);
  delivered(a, "/l", 300, 1, 11 * kS);
  a.on_announced("/l", 300, 1, 11 * kS);  // the same announcement again: no gap, no sample
  a.expire(20 * kS, kS);
  EXPECT_EQ(a.counts("/l").missed, 4u);
  EXPECT_EQ(a.counts("/l").unannounced, 0u);
  // A camera's seq is its frame id: the same gap is `unannounced`, never `missed`.
  a.set_seq_gaps("/c", AnnouncedSamples::SeqGaps::kUnannounced);
  delivered(a, "/c", 10, 1, 20 * kS);
  delivered(a, "/c", 40, 4, 20 * kS);
  a.expire(22 * kS, kS);
  EXPECT_EQ(a.counts("/c").missed, 0u);
  EXPECT_EQ(a.counts("/c").unannounced, 2u);
  // A GigE camera's 16-bit frame id wraps: 65534, (65535, 1 lost), 2; the mock's start near 65500.
  a.set_seq_gaps("/g", AnnouncedSamples::SeqGaps::kUnannounced);
  delivered(a, "/g", 50, 65534, 23 * kS);
  delivered(a, "/g", 80, 2, 23 * kS);
  a.expire(23 * kS, kS);
  EXPECT_EQ(a.counts("/g").unannounced, 2u);
  // The dbw bridge's commands: its seq skips by design, a gap is nothing.
  a.set_seq_gaps("/cmd", AnnouncedSamples::SeqGaps::kNotCounted);
  delivered(a, "/cmd", 10, 1, 20 * kS);
  delivered(a, "/cmd", 40, 9, 20 * kS);
  a.expire(22 * kS, kS);
  EXPECT_EQ(a.counts("/cmd").missed + a.counts("/cmd").unannounced, 0u);
  // At the stop every sample was taken: a gap seen a moment before is decided, an announcement that
  // recent still waits (its sample may be on the way).
  a.on_announced("/l", 400, 5, 30 * kS);  // seqs 2..4: a gap of 3, one received
  a.on_data("/l", 350, 30 * kS);
  a.on_announced("/l", 500, 6, 30 * kS);
  a.expire(30 * kS + 1, kS / 5, 0);
  EXPECT_EQ(a.counts("/l").missed, 4u + 2u);
  EXPECT_EQ(a.held(), 2u);  // the announcements of stamps 400 and 500, a moment old
}

// Announcements their writer numbers (SourceStamps.published): a gap in the number is samples the rig
// published and the recorder lost with their announcements, on a camera as on any topic, whatever
// the device's frame id did meanwhile (frames the camera made and the rig never had are not the
// recorder's). Before, a camera's gaps were all `unannounced`: frames lost before the rig and
// samples the recorder missed in one upper bound.
TEST(RecordGaps, ANumberedCameraGapIsMissedExactlyWhateverItsFrameIdsSkip) {
  constexpr Nanos kS = 1'000'000'000;
  AnnouncedSamples a;
  a.set_seq_gaps("/c", AnnouncedSamples::SeqGaps::kUnannounced);
  // Frame ids 10, 11, (12, 13 the camera made, the rig lost before it), 14 .. 17 published as 3 .. 6.
  a.on_announced("/c", 100, 10, 0, true, 1);
  a.on_data("/c", 100, 0);
  a.on_announced("/c", 110, 11, 0, true, 2);
  a.on_data("/c", 110, 0);
  a.on_announced("/c", 140, 14, 0, true, 3);  // frame ids skip 2: the number does not
  a.on_data("/c", 140, 0);
  // The recorder stopped: 15 and 16 (numbers 4, 5) lost with their announcements; 16's sample came.
  a.on_data("/c", 160, kS);
  a.on_announced("/c", 170, 17, kS, true, 6);
  a.on_data("/c", 170, kS);
  a.expire(2 * kS, kS);
  EXPECT_EQ(a.counts("/c").missed, 1u) << "number 4 (frame 15): lost by the recorder";
  EXPECT_EQ(a.counts("/c").unannounced, 0u) << "frames 12 and 13 never reached the rig: not the recorder's";
  // The driver's process restarted: numbers from 1 again, no gap; then one announcement and its
  // sample lost: missed.
  a.on_announced("/c", 300, 30, 3 * kS, true, 1);
  a.on_data("/c", 300, 3 * kS);
  a.on_announced("/c", 320, 32, 3 * kS, true, 3);
  a.on_data("/c", 320, 3 * kS);
  a.expire(4 * kS, kS);
  EXPECT_EQ(a.counts("/c").missed, 2u);
  EXPECT_EQ(a.counts("/c").unannounced, 0u);
  EXPECT_EQ(a.counts("/c").overflow, 0u);
}

// A model of the rig against a recorder that falls far behind: 7 cameras (~30 Hz), 3 LIDARs and
// the fused cloud (10 Hz), vehicle state (100 Hz) announce every sample on one /rig/stamps writer
// that keeps its last 64; each data writer keeps its last 2. The recorder stops for `stall` and,
// when it resumes, gets what the writers still hold. Truth: per topic, the samples published in
// the counted window minus those received. Rig-wide that is thousands of samples, of which the
// announcements received name only ~64: counting those alone, as rig record did before seq gaps,
// gave 40 for every stall here (of 86, 1,745 and 4,209 missed).
struct RigModel {
  struct Topic {
    std::string name;
    Nanos period = 0;
    bool gapless = true;
    std::uint64_t seq = 0, published = 0, received = 0;
    std::deque<Nanos> unsent;  // data the writer still holds for the recorder
  };
  std::vector<Topic> topics;
  std::deque<std::pair<std::size_t, Nanos>> stamps_unsent;  // (topic, stamp), the stamps writer's
  AnnouncedSamples recorder;

  RigModel() {
    for (int i = 0; i < 7; ++i) add("/sensors/camera/c" + std::to_string(i) + "/image_raw", 33'000'000, false);
    for (int i = 0; i < 3; ++i) add("/sensors/lidar/l" + std::to_string(i) + "/points", 100'000'000, true);
    add("/sensors/lidar/fused/points", 100'000'000, true);
    add("/vehicle/state", 10'000'000, true);
  }
  void add(const std::string& name, Nanos period, bool gapless) {
    Topic& t = topics.emplace_back();
    t.name = name;
    t.period = period;
    t.gapless = gapless;
    recorder.set_seq_gaps(name, gapless ? AnnouncedSamples::SeqGaps::kMissed : AnnouncedSamples::SeqGaps::kUnannounced);
  }

  // Runs from `from` to `to` (ms steps); the recorder takes everything at each step unless stopped.
  void run(Nanos from, Nanos to, bool stopped) {
    for (Nanos now = from; now < to; now += 1'000'000) {
      for (std::size_t i = 0; i < topics.size(); ++i) {
        Topic& t = topics[i];
        if (now % t.period != 0) continue;
        // The stamp stands for a sample: distinct per topic (offset by the topic's index).
        const Nanos stamp = now + static_cast<Nanos>(i);
        ++t.published;
        t.unsent.push_back(stamp);
        if (t.unsent.size() > 2) t.unsent.pop_front();
        stamps_unsent.emplace_back(i, stamp);
        if (stamps_unsent.size() > 64) stamps_unsent.pop_front();
        seqs[stamp] = t.seq++;
      }
      if (stopped) continue;
      // Stamps first, then the data: the order a waitset wakes the recorder in is not the rig's.
      for (const auto& [i, stamp] : stamps_unsent) recorder.on_announced(topics[i].name, stamp, seqs[stamp], now);
      stamps_unsent.clear();
      for (auto& t : topics) {
        for (const Nanos stamp : t.unsent) recorder.on_data(t.name, stamp, now);
        t.received += t.unsent.size();
        t.unsent.clear();
      }
      if (now % 100'000'000 == 0) recorder.expire(now, 1'000'000'000);
    }
  }
  std::map<Nanos, std::uint64_t> seqs;
};

TEST(RecordGaps, ARecorderFarBehindCountsEverySampleItMissed) {
  constexpr Nanos kS = 1'000'000'000;
  for (const Nanos stall : {Nanos{300'000'000}, 5 * kS, 12 * kS}) {
    SCOPED_TRACE(stall);
    RigModel rig;
    rig.run(0, 2 * kS, false);
    rig.run(2 * kS, 2 * kS + stall, true);
    rig.run(2 * kS + stall, 5 * kS + stall, false);
    rig.recorder.expire(10 * kS + stall, 200'000'000);  // the stop
    std::uint64_t lost = 0, counted = 0;
    for (const auto& t : rig.topics) {
      SCOPED_TRACE(t.name);
      const auto c = rig.recorder.counts(t.name);
      const std::uint64_t truth = t.published - t.received;
      lost += truth;
      counted += c.missed + c.unannounced;
      if (t.gapless) {
        EXPECT_EQ(c.missed, truth);
        EXPECT_EQ(c.unannounced, 0u);
      } else {
        // A camera's frames were all published here: missed + unannounced is the truth; missed
        // alone (the announcements that came) is less once its stamps were lost.
        EXPECT_EQ(c.missed + c.unannounced, truth);
        EXPECT_LE(c.missed, truth);
      }
      EXPECT_EQ(c.overflow, 0u);
    }
    std::cout << "stall " << static_cast<double>(stall) / 1e9 << " s: " << lost << " samples missed, counted " << counted
              << "; held at the end " << rig.recorder.held() << "\n";
    EXPECT_EQ(counted, lost);
    EXPECT_GT(lost, 64u);
  }
}

// The bounds: past kMaxPending waiting announcements the oldest is counted missed at once (and in
// overflow); past kMaxGaps undecided gaps the oldest two merge, and the count stays exact.
TEST(RecordGaps, TheBookkeepingIsBoundedAndSaysWhenItDecidedEarly) {
  constexpr Nanos kS = 1'000'000'000;
  constexpr auto kMax = AnnouncedSamples::kMaxPending;
  AnnouncedSamples a;
  // Announcements of a topic whose data never comes, all within one timeout.
  for (std::uint64_t i = 0; i < kMax + 10; ++i) a.on_announced("/flood", static_cast<Nanos>(i + 1), i, 0);
  EXPECT_LE(a.held(), kMax);
  EXPECT_EQ(a.counts("/flood").missed, 10u);
  EXPECT_EQ(a.counts("/flood").overflow, 10u);
  a.expire(2 * kS, kS);
  EXPECT_EQ(a.counts("/flood").missed, kMax + 10);  // every one, once
  EXPECT_EQ(a.held(), 0u);
  // kMaxGaps + 50 gaps of 3 seqs each, one of each gap's samples received: merged, still exact.
  std::uint64_t seq = 0;
  Nanos stamp = 0;
  for (std::size_t g = 0; g < AnnouncedSamples::kMaxGaps + 50; ++g) {
    a.on_announced("/gaps", stamp += 10, seq, 3 * kS);
    a.on_data("/gaps", stamp, 3 * kS);
    a.on_data("/gaps", stamp + 5, 3 * kS);  // seq + 2's sample, its stamps lost
    seq += 4;
  }
  EXPECT_LE(a.held(), AnnouncedSamples::kMaxGaps + AnnouncedSamples::kMaxPending);
  a.expire(5 * kS, kS);
  EXPECT_EQ(a.counts("/gaps").missed, 2 * (AnnouncedSamples::kMaxGaps + 49));  // the last has no gap after it
  EXPECT_EQ(a.counts("/gaps").overflow, 50u - 1);
}

}  // namespace
}  // namespace sensor_rig::rig
