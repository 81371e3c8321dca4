// DiscoveryReader: the writers of another participant, with type, GUID, host and reliability, and
// their going away. Two real participants on a domain of their own.
#include <gtest/gtest.h>
#include <unistd.h>

#include <map>
#include <string>
#include <vector>

#include "sensor_rig/dds/discovery.hpp"
#include "sensor_rig/dds/types.hpp"
#include "sensor_rig/dds/waitset.hpp"
#include "wait_bounds.hpp"

namespace sensor_rig::dds {
namespace {

constexpr dds_domainid_t kDomain = 41;

std::string unique_topic(const char* what) { return "/test/discovery/" + std::to_string(::getpid()) + "/" + what; }

// Takes until `done(seen)` holds or 5 s pass; only publications on our own topics (other tests
// may share the machine), keyed by writer GUID.
template <class Done>
std::map<std::string, Publication> take_until(DiscoveryReader& d, WaitSet& ws, const std::string& prefix, Done done) {
  std::map<std::string, Publication> seen;
  std::vector<std::int64_t> tags;
  const Nanos deadline = monotonic_now_ns() + Nanos{test::kDiscoveryMs} * 1'000'000;
  while (!done(seen) && monotonic_now_ns() < deadline) {
    ws.wait(tags, 50'000'000);
    for (auto& p : d.take()) {
      if (!p.alive) {
        if (auto it = seen.find(p.writer_guid); it != seen.end()) it->second.alive = false;
        continue;
      }
      if (p.topic.rfind(prefix, 0) == 0) seen[p.writer_guid] = p;
    }
  }
  return seen;
}

TEST(DdsDiscovery, SeesAnotherParticipantsWritersWithTypeGuidHostAndReliability) {
  Participant mine(DomainConfig{kDomain, {}});
  DiscoveryReader discovery(mine);
  WaitSet ws(mine);
  ws.attach_reader(discovery.handle(), 1);

  Participant theirs(DomainConfig{kDomain, {}});
  const std::string stamps_name = unique_topic("stamps"), points_name = unique_topic("points");
  Topic<msg::SourceStamps> stamps_topic(theirs, stamps_name);
  Writer<msg::SourceStamps> stamps_writer(theirs, stamps_topic);
  QosSpec best_effort;
  best_effort.reliability = QosSpec::Reliability::kBestEffort;
  Topic<msg::PointCloud2> points_topic(theirs, points_name, best_effort);
  auto points_writer = std::make_unique<Writer<msg::PointCloud2>>(theirs, points_topic, best_effort);

  const std::string prefix = ros_to_dds_topic(unique_topic(""));
  auto seen = take_until(discovery, ws, prefix, [](const auto& s) { return s.size() >= 2; });
  ASSERT_EQ(seen.size(), 2u);
  std::map<std::string, Publication> by_topic;
  for (const auto& [guid, p] : seen) {
    EXPECT_EQ(guid.size(), 32u);
    EXPECT_EQ(guid.find_first_not_of("0123456789abcdef"), std::string::npos) << guid;
    EXPECT_EQ(p.participant_guid.size(), 32u);
    EXPECT_NE(p.participant_guid, guid);
    by_topic[p.topic] = p;
  }
  ASSERT_TRUE(by_topic.contains("rt" + stamps_name));
  ASSERT_TRUE(by_topic.contains("rt" + points_name));
  const auto& stamps = by_topic["rt" + stamps_name];
  const auto& points = by_topic["rt" + points_name];
  EXPECT_EQ(stamps.type, "sensor_rig_msgs::msg::dds_::SourceStamps_");
  EXPECT_EQ(points.type, "sensor_msgs::msg::dds_::PointCloud2_");
  EXPECT_EQ(stamps.reliability, QosSpec::Reliability::kReliable);
  EXPECT_EQ(points.reliability, QosSpec::Reliability::kBestEffort);
  EXPECT_EQ(stamps.participant_guid, points.participant_guid);  // one participant, two writers
  char host[256] = {};
  ASSERT_EQ(::gethostname(host, sizeof host - 1), 0);
  EXPECT_EQ(stamps.host, host);

  // The points writer goes away: reported as not alive, by GUID; the stamps writer stays.
  const std::string gone = points.writer_guid;
  points_writer.reset();
  std::vector<std::int64_t> tags;
  bool went_away = false, other_went = false;
  const Nanos deadline = monotonic_now_ns() + Nanos{test::kDiscoveryMs} * 1'000'000;
  while (!went_away && monotonic_now_ns() < deadline) {
    ws.wait(tags, 50'000'000);
    for (const auto& p : discovery.take()) {
      if (p.alive) continue;
      EXPECT_TRUE(p.topic.empty());
      went_away = went_away || p.writer_guid == gone;
      other_went = other_went || p.writer_guid == stamps.writer_guid;
    }
  }
  EXPECT_TRUE(went_away);
  EXPECT_FALSE(other_went);
}

TEST(DdsDiscovery, ALateReaderSeesWritersThatWereThereBefore) {
  Participant theirs(DomainConfig{kDomain, {}});
  const std::string name = unique_topic("before");
  Topic<msg::SourceStamps> topic(theirs, name);
  Writer<msg::SourceStamps> writer(theirs, topic);
  Participant mine(DomainConfig{kDomain, {}});
  DiscoveryReader discovery(mine);
  WaitSet ws(mine);
  ws.attach_reader(discovery.handle(), 1);
  const auto seen = take_until(discovery, ws, "rt" + name, [](const auto& s) { return !s.empty(); });
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen.begin()->second.topic, "rt" + name);
}

}  // namespace
}  // namespace sensor_rig::dds
