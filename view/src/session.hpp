#pragma once
// One client connection of the server (server.cpp only: it names Beast types). The fields marked
// (mu) are guarded by Server::Impl::mu; the stream and the buffers in flight belong to the I/O thread.
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/http/message.hpp>
#include <boost/beast/http/string_body.hpp>
#include <boost/beast/websocket/stream.hpp>

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "sensor_rig/view/latest_queue.hpp"
#include "sensor_rig/view/protocol.hpp"

namespace sensor_rig::view {

// A message data frame waiting for one client: its own header (subscription id), the payload
// shared with every other subscriber of the sample.
struct QueuedMessage {
  std::uint64_t seq = 0;  // publish order over all channels
  std::array<std::uint8_t, kMessageDataHeaderBytes> header{};
  std::shared_ptr<const std::vector<std::uint8_t>> payload;
};

struct Subscription {
  ChannelId channel = 0;
  LatestQueue<QueuedMessage> queue;
  std::uint64_t sent = 0;
  std::uint64_t reported_dropped = 0;  // drops already told the client in a status warning
};

// Whether a Sec-WebSocket-Protocol header (a comma-separated list) offers ours.
inline bool offers_subprotocol(const std::string& header) {
  std::stringstream in(header);
  std::string token;
  while (std::getline(in, token, ',')) {
    const auto b = token.find_first_not_of(" \t");
    const auto e = token.find_last_not_of(" \t");
    if (b != std::string::npos && token.substr(b, e - b + 1) == kSubprotocol) return true;
  }
  return false;
}

struct Session {
  explicit Session(boost::asio::ip::tcp::socket socket) : ws(std::move(socket)) {}

  // I/O thread.
  boost::beast::websocket::stream<boost::beast::tcp_stream> ws;
  boost::beast::flat_buffer read_buf;
  boost::beast::http::request<boost::beast::http::string_body> request;
  std::string text_out;  // the frame being written
  std::array<std::uint8_t, kTimeBytes> time_out{};
  QueuedMessage data_out;
  std::string peer;
  std::uint64_t id = 0;

  // (mu)
  bool open = false;         // handshake done, not closed
  bool writing = false;      // an async_write is in flight
  bool pump_posted = false;  // a pump() is queued on the I/O thread
  bool overflow = false;     // control queue overflowed: being closed
  bool closing = false;      // the server stops: a WebSocket close after the write in flight
  std::deque<std::string> control;
  std::optional<std::uint64_t> time_pending;
  std::map<SubscriptionId, Subscription> subs;
  std::uint64_t messages_sent = 0;
  std::uint64_t bytes_sent = 0;
  std::uint64_t past_dropped = 0;  // of subscriptions that ended
  std::uint64_t protocol_errors = 0;

  [[nodiscard]] bool subscribed_to(ChannelId ch) const {
    for (const auto& [id_, s] : subs)
      if (s.channel == ch) return true;
    return false;
  }
  // The subscription whose next message was published first; nullptr when all are empty.
  Subscription* oldest_data() {
    Subscription* best = nullptr;
    for (auto& [id_, s] : subs)
      if (!s.queue.empty() && (best == nullptr || s.queue.front().seq < best->queue.front().seq)) best = &s;
    return best;
  }
};

}  // namespace sensor_rig::view
