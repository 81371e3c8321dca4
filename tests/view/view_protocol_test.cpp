// The Foxglove protocol's messages as the spec (ws-protocol docs/spec.md) lays them out, the parse of
// client requests (every malformed kind a reason, never a throw), and the drop-oldest queue.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "sensor_rig/view/latest_queue.hpp"
#include "sensor_rig/view/protocol.hpp"

namespace sensor_rig::view {
namespace {

using nlohmann::json;

TEST(ViewProtocol, ServerMessagesCarryTheSpecsFields) {
  const json info = json::parse(server_info_json("rig", {"time"}, "42"));
  EXPECT_EQ(info["op"], "serverInfo");
  EXPECT_EQ(info["name"], "rig");
  EXPECT_EQ(info["capabilities"], json::array({"time"}));
  EXPECT_TRUE(info["supportedEncodings"].is_array());
  EXPECT_EQ(info["sessionId"], "42");

  const json adv = json::parse(advertise_json(
      {Channel{7, ChannelSpec{"/a", "cdr", "pkg/msg/T", "int32 x\n", "ros2msg"}}}));
  ASSERT_EQ(adv["channels"].size(), 1u);
  EXPECT_EQ(adv["op"], "advertise");
  EXPECT_EQ(adv["channels"][0]["id"], 7);
  EXPECT_EQ(adv["channels"][0]["topic"], "/a");
  EXPECT_EQ(adv["channels"][0]["encoding"], "cdr");
  EXPECT_EQ(adv["channels"][0]["schemaName"], "pkg/msg/T");
  EXPECT_EQ(adv["channels"][0]["schema"], "int32 x\n");
  EXPECT_EQ(adv["channels"][0]["schemaEncoding"], "ros2msg");
  EXPECT_EQ(json::parse(advertise_json({}))["channels"], json::array());

  EXPECT_EQ(json::parse(unadvertise_json({1, 2}))["channelIds"], json::array({1, 2}));
  const json st = json::parse(status_json(StatusLevel::kError, "bad"));
  EXPECT_EQ(st["level"], 2);
  EXPECT_EQ(st["message"], "bad");
  // Bytes that are not UTF-8 (a topic name from the wire) do not throw.
  json replaced;
  EXPECT_NO_THROW(replaced = json::parse(status_json(StatusLevel::kInfo, std::string("\xff\xfe", 2))));
  EXPECT_EQ(replaced["message"], "\xEF\xBF\xBD\xEF\xBF\xBD");  // U+FFFD twice
}

TEST(ViewProtocol, BinaryFramesAreLittleEndian) {
  const auto h = message_data_header(0x01020304u, 0x1112131415161718ull);
  const std::array<std::uint8_t, 13> want{0x01, 0x04, 0x03, 0x02, 0x01, 0x18, 0x17, 0x16, 0x15, 0x14, 0x13, 0x12, 0x11};
  EXPECT_EQ(h, want);
  const auto t = time_message(0x0102030405060708ull);
  const std::array<std::uint8_t, 9> want_t{0x02, 0x08, 0x07, 0x06, 0x05, 0x04, 0x03, 0x02, 0x01};
  EXPECT_EQ(t, want_t);
}

TEST(ViewProtocol, ClientRequestsParse) {
  auto r = parse_client_text(R"({"op":"subscribe","subscriptions":[{"id":0,"channelId":3},{"id":1,"channelId":5}]})");
  ASSERT_EQ(r.kind, ClientRequest::Kind::kSubscribe) << r.error;
  ASSERT_EQ(r.subscribe.size(), 2u);
  EXPECT_EQ(r.subscribe[1], (std::pair<SubscriptionId, ChannelId>{1, 5}));
  r = parse_client_text(R"({"op":"unsubscribe","subscriptionIds":[0,4294967295]})");
  ASSERT_EQ(r.kind, ClientRequest::Kind::kUnsubscribe) << r.error;
  EXPECT_EQ(r.unsubscribe, (std::vector<SubscriptionId>{0, 4294967295u}));
}

TEST(ViewProtocol, MalformedRequestsAreErrorsWithAReason) {
  const std::pair<const char*, const char*> cases[] = {
      {"not json", "not valid JSON"},
      {"[1]", "JSON object"},
      {R"({"op":3})", "missing \"op\""},
      {R"({"x":1})", "missing \"op\""},
      {R"({"op":"frob"})", "unknown op \"frob\""},
      {R"({"op":"setParameters","parameters":[]})", "capability"},
      {R"({"op":"subscribe"})", "\"subscriptions\" must be an array"},
      {R"({"op":"subscribe","subscriptions":[1]})", "must be an object"},
      {R"({"op":"subscribe","subscriptions":[{"id":1}]})", "missing \"channelId\""},
      {R"({"op":"subscribe","subscriptions":[{"id":-1,"channelId":1}]})", "non-negative"},
      {R"({"op":"subscribe","subscriptions":[{"id":1.5,"channelId":1}]})", "non-negative"},
      {R"({"op":"subscribe","subscriptions":[{"id":4294967296,"channelId":1}]})", "32 bits"},
      {R"({"op":"unsubscribe","subscriptionIds":["a"]})", "non-negative"},
      {R"({"op":"unsubscribe"})", "must be an array"},
  };
  for (const auto& [text, reason] : cases) {
    const auto r = parse_client_text(text);
    EXPECT_EQ(r.kind, ClientRequest::Kind::kError) << text;
    EXPECT_NE(r.error.find(reason), std::string::npos) << text << " -> " << r.error;
  }
}

TEST(ViewLatestQueue, KeepsTheNewestAndCountsDrops) {
  LatestQueue<int> q(QueueLimits{3, 3, 1 << 20});
  for (int i = 0; i < 3; ++i) EXPECT_EQ(q.push(i, 10), 0u);
  EXPECT_EQ(q.push(3, 10), 1u);
  EXPECT_EQ(q.push(4, 10), 1u);
  EXPECT_EQ(q.dropped(), 2u);
  ASSERT_EQ(q.size(), 3u);
  EXPECT_EQ(q.bytes(), 30u);
  EXPECT_EQ(q.pop(), 2);
  EXPECT_EQ(q.pop(), 3);
  EXPECT_EQ(q.pop(), 4);
  EXPECT_TRUE(q.empty());
  EXPECT_EQ(q.bytes(), 0u);
  LatestQueue<int> zero(QueueLimits{0, 0, 0});  // a depth of 0 would drop everything: it holds one
  EXPECT_EQ(zero.push(1, 1), 0u);
  EXPECT_EQ(zero.push(2, 1), 1u);
  EXPECT_EQ(zero.front(), 2);
}

TEST(ViewLatestQueue, SmallMessagesQueueDeeperThanLargeOnes) {
  // 1 MB clouds: the minimum of 2, whatever the byte budget says.
  LatestQueue<int> clouds(QueueLimits{2, 256, 1 << 20});
  for (int i = 0; i < 5; ++i) clouds.push(i, 1'000'000);
  EXPECT_EQ(clouds.size(), 2u);
  EXPECT_EQ(clouds.front(), 3);
  EXPECT_EQ(clouds.dropped(), 3u);
  // 200-byte stamps: as many as fit in the budget, capped at max_items.
  LatestQueue<int> stamps(QueueLimits{2, 100, 1 << 20});
  for (int i = 0; i < 150; ++i) stamps.push(i, 200);
  EXPECT_EQ(stamps.size(), 100u);
  EXPECT_EQ(stamps.front(), 50);
  // Mixed: a large push evicts small ones down to the minimum, never the new one.
  LatestQueue<int> mixed(QueueLimits{2, 100, 1000});
  for (int i = 0; i < 4; ++i) mixed.push(i, 100);
  EXPECT_EQ(mixed.push(9, 5000), 3u);
  EXPECT_EQ(mixed.size(), 2u);
  EXPECT_EQ(mixed.front(), 3);
}

}  // namespace
}  // namespace sensor_rig::view
