#pragma once
// A Foxglove WebSocket server (protocol.hpp): channels the owner adds and removes, client
// subscriptions, message data to every subscriber. One I/O thread of its own serves every client
// (Boost.Beast, kept inside server.cpp: this header names none of it).
//
// Never blocking the caller: publish() copies the payload once, appends it to each subscriber's
// queue (LatestQueue: bounded, drops its oldest) and returns; the I/O thread writes when the
// client's socket takes it. A client that stops reading loses its oldest samples, counted per
// subscription and told in a status warning each second, while every other client and the
// publisher go on at full rate.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "sensor_rig/view/latest_queue.hpp"
#include "sensor_rig/view/protocol.hpp"

namespace sensor_rig::view {

struct ServerOptions {
  std::string address = "127.0.0.1";  // loopback unless told otherwise
  std::uint16_t port = 8765;          // 0: a free port (port() tells which)
  std::string name = "sensor-rig";
  // Per subscription (latest_queue.hpp): at least queue.min_items messages, more while they fit in
  // queue.max_bytes; beyond that the oldest is dropped.
  QueueLimits queue;
  // Text messages (advertise, status) waiting for one client: past this it is disconnected (its
  // channel list would be wrong if any were dropped), counted in closed_overflow.
  std::size_t control_limit = 4096;
  int time_interval_ms = 50;  // `time` messages (capability `time`); 0: no time capability
};

struct SubscriptionStats {
  SubscriptionId id = 0;
  ChannelId channel = 0;
  std::string topic;
  std::uint64_t sent = 0;
  std::uint64_t dropped = 0;  // oldest dropped from a full queue (client too slow)
  std::size_t queued = 0;
};

struct ClientStats {
  std::uint64_t id = 0;  // the server's connection number
  std::string peer;      // address:port
  std::uint64_t messages_sent = 0;  // message data frames written
  std::uint64_t bytes_sent = 0;     // of those frames
  std::uint64_t dropped = 0;        // over every subscription, past ones included
  std::uint64_t protocol_errors = 0;
  std::vector<SubscriptionStats> subscriptions;
};

struct ServerStats {
  std::uint64_t clients_accepted = 0;  // WebSocket handshakes completed
  std::uint64_t clients_rejected = 0;  // bad handshakes (not WebSocket, no foxglove.websocket.v1)
  std::uint64_t clients_closed = 0;
  std::uint64_t closed_overflow = 0;   // of those: disconnected for an overflowing control queue
  std::uint64_t published = 0;         // publish() calls with at least one subscriber
  std::uint64_t dropped = 0;           // queue drops over every client, past ones included
  std::uint64_t protocol_errors = 0;   // bad client messages answered with a status error
  std::size_t channels = 0;
  std::vector<ClientStats> clients;  // the connected ones
};

class Server {
 public:
  // Called on the I/O thread when a channel gets its first subscriber over all clients, and when it
  // loses its last one (unsubscribe, disconnect). Not called for a channel the owner removed.
  struct Callbacks {
    std::function<void(ChannelId)> first_subscriber;
    std::function<void(ChannelId)> last_unsubscribed;
  };

  // Binds and listens at once (throws std::system_error naming the address on failure); serves
  // from start() on.
  explicit Server(ServerOptions options);
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;
  ~Server();  // stop()

  [[nodiscard]] std::uint16_t port() const noexcept;
  [[nodiscard]] const ServerOptions& options() const noexcept;
  void start(Callbacks callbacks = {});
  // Closes every connection (a WebSocket close where the client still reads, else the socket) and
  // joins the I/O thread within ~1 s. Idempotent.
  void stop();

  // Thread-safe. add_channel advertises to every client (ids are never reused); remove_channel
  // unadvertises and ends the channel's subscriptions.
  ChannelId add_channel(ChannelSpec spec);
  void remove_channel(ChannelId id);
  [[nodiscard]] bool has_subscribers(ChannelId id) const;
  // Copies the payload once for every subscriber of `channel`; never blocks on a client. The
  // payload may come in pieces (a shared-memory sample: a header made by the reader, then the chunk).
  void publish(ChannelId channel, std::uint64_t receive_ns, std::span<const std::span<const std::uint8_t>> pieces);
  void publish(ChannelId channel, std::uint64_t receive_ns, const std::uint8_t* data, std::size_t size) {
    const std::span<const std::uint8_t> one[] = {{data, size}};
    publish(channel, receive_ns, one);
  }
  void broadcast_status(StatusLevel level, const std::string& message);

  [[nodiscard]] ServerStats stats() const;

  struct Impl;  // server.cpp

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace sensor_rig::view
