#include "sensor_rig/view/protocol.hpp"

#include <limits>
#include <nlohmann/json.hpp>

namespace sensor_rig::view {
namespace {

using nlohmann::json;

// Topic names, schemas and a client's own op names can hold bytes that are not UTF-8; they are
// replaced (U+FFFD) rather than throwing halfway through a message.
std::string dump(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

template <std::size_t N>
void put_le(std::array<std::uint8_t, N>& out, std::size_t at, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (8 * i));
}

// A u32 field of a client's object: a non-negative integer that fits, else the reason.
bool get_u32(const json& obj, const char* key, std::uint32_t& out, std::string& why) {
  const auto it = obj.find(key);
  if (it == obj.end()) {
    why = std::string("missing \"") + key + "\"";
    return false;
  }
  if (!it->is_number_unsigned() && !(it->is_number_integer() && it->get<std::int64_t>() >= 0)) {
    why = std::string("\"") + key + "\" is not a non-negative integer";
    return false;
  }
  const auto v = it->get<std::uint64_t>();
  if (v > std::numeric_limits<std::uint32_t>::max()) {
    why = std::string("\"") + key + "\" exceeds 32 bits";
    return false;
  }
  out = static_cast<std::uint32_t>(v);
  return true;
}

ClientRequest error(std::string why) {
  ClientRequest r;
  r.kind = ClientRequest::Kind::kError;
  r.error = std::move(why);
  return r;
}

ClientRequest parse_subscribe(const json& j) {
  const auto it = j.find("subscriptions");
  if (it == j.end() || !it->is_array()) return error("subscribe: \"subscriptions\" must be an array");
  ClientRequest r;
  r.kind = ClientRequest::Kind::kSubscribe;
  for (const auto& s : *it) {
    if (!s.is_object()) return error("subscribe: each subscription must be an object");
    std::uint32_t id = 0;
    std::uint32_t channel = 0;
    std::string why;
    if (!get_u32(s, "id", id, why) || !get_u32(s, "channelId", channel, why)) return error("subscribe: " + why);
    r.subscribe.emplace_back(id, channel);
  }
  return r;
}

ClientRequest parse_unsubscribe(const json& j) {
  const auto it = j.find("subscriptionIds");
  if (it == j.end() || !it->is_array()) return error("unsubscribe: \"subscriptionIds\" must be an array");
  ClientRequest r;
  r.kind = ClientRequest::Kind::kUnsubscribe;
  for (const auto& s : *it) {
    if (!s.is_number_unsigned() && !(s.is_number_integer() && s.get<std::int64_t>() >= 0))
      return error("unsubscribe: subscription ids must be non-negative integers");
    const auto v = s.get<std::uint64_t>();
    if (v > std::numeric_limits<std::uint32_t>::max()) return error("unsubscribe: a subscription id exceeds 32 bits");
    r.unsubscribe.push_back(static_cast<std::uint32_t>(v));
  }
  return r;
}

}  // namespace

std::string server_info_json(std::string_view name, const std::vector<std::string>& capabilities,
                             std::string_view session_id) {
  // supportedEncodings lists what a client may publish or call services with: nothing here (no
  // clientPublish, no services), so an empty list rather than leaving a client to guess.
  return dump(json{{"op", "serverInfo"},
                   {"name", name},
                   {"capabilities", capabilities},
                   {"supportedEncodings", json::array()},
                   {"metadata", json::object()},
                   {"sessionId", session_id}});
}

std::string advertise_json(const std::vector<Channel>& channels) {
  json list = json::array();
  for (const auto& c : channels)
    list.push_back(json{{"id", c.id},
                        {"topic", c.spec.topic},
                        {"encoding", c.spec.encoding},
                        {"schemaName", c.spec.schema_name},
                        {"schema", c.spec.schema},
                        {"schemaEncoding", c.spec.schema_encoding}});
  return dump(json{{"op", "advertise"}, {"channels", std::move(list)}});
}

std::string unadvertise_json(const std::vector<ChannelId>& ids) {
  return dump(json{{"op", "unadvertise"}, {"channelIds", ids}});
}

std::string status_json(StatusLevel level, std::string_view message) {
  return dump(json{{"op", "status"}, {"level", static_cast<int>(level)}, {"message", message}});
}

std::array<std::uint8_t, kMessageDataHeaderBytes> message_data_header(SubscriptionId sub, std::uint64_t receive_ns) {
  std::array<std::uint8_t, kMessageDataHeaderBytes> h{};
  h[0] = static_cast<std::uint8_t>(BinaryOp::kMessageData);
  put_le(h, 1, sub, 4);
  put_le(h, 5, receive_ns, 8);
  return h;
}

std::array<std::uint8_t, kTimeBytes> time_message(std::uint64_t ns) {
  std::array<std::uint8_t, kTimeBytes> t{};
  t[0] = static_cast<std::uint8_t>(BinaryOp::kTime);
  put_le(t, 1, ns, 8);
  return t;
}

ClientRequest parse_client_text(std::string_view text) {
  json j = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return error("not valid JSON");
  if (!j.is_object()) return error("a text message must be a JSON object");
  const auto op = j.find("op");
  if (op == j.end() || !op->is_string()) return error("missing \"op\" (a string)");
  const auto& name = op->get_ref<const std::string&>();
  if (name == "subscribe") return parse_subscribe(j);
  if (name == "unsubscribe") return parse_unsubscribe(j);
  // Known ops of capabilities this server does not declare (clientPublish, parameters, services,
  // connectionGraph, assets): said as such, so a client author sees why.
  static const char* const kUndeclared[] = {"advertise", "unadvertise", "getParameters", "setParameters",
                                            "subscribeParameterUpdates", "unsubscribeParameterUpdates",
                                            "subscribeConnectionGraph", "unsubscribeConnectionGraph",
                                            "fetchAsset"};
  for (const char* k : kUndeclared)
    if (name == k) return error("op \"" + name + "\" needs a capability this server does not declare");
  return error("unknown op \"" + name + "\"");
}

}  // namespace sensor_rig::view
