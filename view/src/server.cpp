// The Foxglove WebSocket server on Boost.Beast (Asio), the only file that includes either: Beast's
// headers cost ~30 s of compile time per translation unit, so they stay here behind server.hpp.
//
// Threads: the I/O thread runs every socket operation; publish(), add_channel() and the like come
// from the owner's threads. Both meet in Impl's one mutex, which guards the channel table and each
// session's queues and flags; socket calls happen only on the I/O thread, outside the mutex.
// A session writes one frame at a time: control text first (serverInfo, advertise, status), then
// the latest `time`, then message data in publish order across its subscriptions.
#include "sensor_rig/view/server.hpp"

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

#include <atomic>
#include <chrono>
#include <map>
#include <mutex>
#include <stdexcept>
#include <system_error>
#include <thread>

#include "sensor_rig/common/clock.hpp"
#include "sensor_rig/common/log.hpp"
#include "session.hpp"

namespace sensor_rig::view {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = net::ip::tcp;

// Handlers capture the Impl by pointer: it outlives the I/O thread (stop() joins it), and the
// io_context destroys handlers it never ran without any reference back to the Impl.
struct Server::Impl {
  explicit Impl(ServerOptions o) : options(std::move(o)), acceptor(ioc), time_timer(ioc), report_timer(ioc) {}

  ServerOptions options;
  net::io_context ioc;
  tcp::acceptor acceptor;
  net::steady_timer time_timer;
  net::steady_timer report_timer;
  std::thread thread;
  std::atomic<bool> stopping{false};
  Callbacks callbacks;
  std::string session_id;
  std::uint16_t port = 0;

  mutable std::mutex mu;  // everything below
  std::map<ChannelId, Channel> channels;
  std::map<ChannelId, int> subscribers;  // channel -> subscriptions over all sessions
  std::map<std::uint64_t, std::shared_ptr<Session>> sessions;
  ChannelId next_channel = 1;
  std::uint64_t next_session = 1;
  std::uint64_t seq = 0;
  ServerStats totals;  // counters only (clients and channels filled in by stats())

  // --- with mu held ---------------------------------------------------------------------------
  void schedule_locked(const std::shared_ptr<Session>& s) {
    if (s->pump_posted || s->writing || !s->open) return;
    s->pump_posted = true;
    net::post(ioc, [self = this, s] { self->pump(s); });
  }
  void control_locked(const std::shared_ptr<Session>& s, std::string text) {
    if (!s->open) return;
    if (s->control.size() >= options.control_limit) {
      if (!s->overflow) {
        s->overflow = true;
        net::post(ioc, [self = this, s] { self->close_session(s, "control queue overflow"); });
      }
      return;
    }
    s->control.push_back(std::move(text));
    schedule_locked(s);
  }
  // Ends a session's subscription; returns true when its channel has no subscriber left.
  bool end_subscription_locked(Session& s, std::map<SubscriptionId, Subscription>::iterator it) {
    s.past_dropped += it->second.queue.dropped();
    const ChannelId ch = it->second.channel;
    s.subs.erase(it);
    const auto c = subscribers.find(ch);
    if (c == subscribers.end()) return false;
    if (--c->second > 0) return false;
    subscribers.erase(c);
    return true;
  }

  // --- I/O thread -----------------------------------------------------------------------------
  void accept();
  void handshake(const std::shared_ptr<Session>& s);
  void reject(const std::shared_ptr<Session>& s, http::status status, std::string body);
  void opened(const std::shared_ptr<Session>& s);
  void read(const std::shared_ptr<Session>& s);
  void handle_text(const std::shared_ptr<Session>& s, const std::string& text);
  void pump(const std::shared_ptr<Session>& s);
  void close_session(const std::shared_ptr<Session>& s, const std::string& why);
  void tick_time();
  void tick_report();
  void notify(const std::vector<ChannelId>& firsts, const std::vector<ChannelId>& lasts) const {
    for (const ChannelId c : firsts)
      if (callbacks.first_subscriber) callbacks.first_subscriber(c);
    for (const ChannelId c : lasts)
      if (callbacks.last_unsubscribed) callbacks.last_unsubscribed(c);
  }
};

// ------------------------------------------------------------------------------------------------
// Connections

void Server::Impl::accept() {
  acceptor.async_accept([self = this](beast::error_code ec, tcp::socket socket) {
    if (self->stopping || !self->acceptor.is_open()) return;
    if (!ec) {
      beast::error_code pe;
      const auto ep = socket.remote_endpoint(pe);
      auto s = std::make_shared<Session>(std::move(socket));
      s->peer = pe ? std::string("?") : ep.address().to_string() + ":" + std::to_string(ep.port());
      self->handshake(s);
    } else {
      log::warn("view", "accept: " + ec.message());
    }
    self->accept();
  });
}

void Server::Impl::handshake(const std::shared_ptr<Session>& s) {
  // A peer that connects and says nothing is dropped after 10 s (it would hold a socket forever).
  s->ws.next_layer().expires_after(std::chrono::seconds(10));
  http::async_read(s->ws.next_layer(), s->read_buf, s->request,
                   [self = this, s](beast::error_code ec, std::size_t) {
                     if (ec) {
                       std::lock_guard lock(self->mu);
                       ++self->totals.clients_rejected;
                       return;  // the socket closes with the session
                     }
                     if (!websocket::is_upgrade(s->request)) {
                       self->reject(s, http::status::upgrade_required,
                                    "This is a Foxglove WebSocket server (foxglove.websocket.v1): open it in "
                                    "Foxglove or Lichtblick as a Foxglove WebSocket connection.\n");
                       return;
                     }
                     if (!offers_subprotocol(std::string(s->request[http::field::sec_websocket_protocol]))) {
                       self->reject(s, http::status::bad_request,
                                    "Sec-WebSocket-Protocol must offer foxglove.websocket.v1\n");
                       return;
                     }
                     s->ws.next_layer().expires_never();
                     s->ws.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
                     s->ws.set_option(websocket::stream_base::decorator([](websocket::response_type& res) {
                       res.set(http::field::sec_websocket_protocol, std::string(kSubprotocol));
                       res.set(http::field::server, "sensor-rig rig view");
                     }));
                     // Whole messages in one frame: clouds of megabytes are not cut into 4 kB frames.
                     s->ws.auto_fragment(false);
                     s->ws.read_message_max(1 << 20);
                     s->ws.async_accept(s->request, [self, s](beast::error_code aec) {
                       if (aec) {
                         std::lock_guard lock(self->mu);
                         ++self->totals.clients_rejected;
                         return;
                       }
                       // Clients send nothing before the 101; whatever the HTTP parse left would
                       // otherwise prefix the first message.
                       s->read_buf.consume(s->read_buf.size());
                       self->opened(s);
                     });
                   });
}

void Server::Impl::reject(const std::shared_ptr<Session>& s, http::status status, std::string body) {
  {
    std::lock_guard lock(mu);
    ++totals.clients_rejected;
  }
  auto res = std::make_shared<http::response<http::string_body>>(status, s->request.version());
  res->set(http::field::content_type, "text/plain");
  res->keep_alive(false);
  res->body() = std::move(body);
  res->prepare_payload();
  http::async_write(s->ws.next_layer(), *res, [s, res](beast::error_code, std::size_t) {
    beast::error_code ignored;
    s->ws.next_layer().socket().shutdown(tcp::socket::shutdown_both, ignored);
  });
}

void Server::Impl::opened(const std::shared_ptr<Session>& s) {
  {
    std::lock_guard lock(mu);
    if (stopping) return;
    s->id = next_session++;
    s->open = true;
    sessions[s->id] = s;
    ++totals.clients_accepted;
    std::vector<std::string> caps;
    if (options.time_interval_ms > 0) caps.emplace_back("time");
    control_locked(s, server_info_json(options.name, caps, session_id));
    std::vector<Channel> list;
    for (const auto& [id, c] : channels) list.push_back(c);
    control_locked(s, advertise_json(list));  // always one, even empty (spec)
  }
  log::info("view", "client " + std::to_string(s->id) + " connected from " + s->peer);
  read(s);
}

void Server::Impl::read(const std::shared_ptr<Session>& s) {
  s->ws.async_read(s->read_buf, [self = this, s](beast::error_code ec, std::size_t) {
    if (ec) {
      self->close_session(s, ec == websocket::error::closed ? "closed by the client" : ec.message());
      return;
    }
    if (s->ws.got_text()) {
      self->handle_text(s, beast::buffers_to_string(s->read_buf.data()));
    } else {
      std::lock_guard lock(self->mu);
      ++s->protocol_errors;
      ++self->totals.protocol_errors;
      self->control_locked(s, status_json(StatusLevel::kError,
                                          "binary client messages need clientPublish or services, which this "
                                          "server does not declare"));
    }
    s->read_buf.consume(s->read_buf.size());
    self->read(s);
  });
}

void Server::Impl::handle_text(const std::shared_ptr<Session>& s, const std::string& text) {
  const ClientRequest req = parse_client_text(text);
  std::vector<ChannelId> firsts;
  std::vector<ChannelId> lasts;
  {
    std::lock_guard lock(mu);
    std::vector<std::string> errors;
    if (req.kind == ClientRequest::Kind::kError) errors.push_back(req.error);
    for (const auto& [sub, ch] : req.subscribe) {
      const auto c = channels.find(ch);
      if (c == channels.end()) {
        errors.push_back("subscribe: no channel " + std::to_string(ch));
      } else if (s->subs.count(sub) != 0) {
        errors.push_back("subscribe: subscription id " + std::to_string(sub) + " is in use");
      } else if (s->subscribed_to(ch)) {
        errors.push_back("subscribe: already subscribed to channel " + std::to_string(ch) + " (" + c->second.spec.topic +
                         ")");
      } else {
        s->subs.emplace(sub, Subscription{ch, LatestQueue<QueuedMessage>(options.queue)});
        if (++subscribers[ch] == 1) firsts.push_back(ch);
      }
    }
    for (const SubscriptionId sub : req.unsubscribe) {
      const auto it = s->subs.find(sub);
      if (it == s->subs.end()) {
        errors.push_back("unsubscribe: no subscription " + std::to_string(sub));
        continue;
      }
      const ChannelId ch = it->second.channel;
      if (end_subscription_locked(*s, it)) lasts.push_back(ch);
    }
    for (const auto& e : errors) {
      ++s->protocol_errors;
      ++totals.protocol_errors;
      control_locked(s, status_json(StatusLevel::kError, e));
    }
  }
  notify(firsts, lasts);
}

void Server::Impl::close_session(const std::shared_ptr<Session>& s, const std::string& why) {
  std::vector<ChannelId> lasts;
  {
    std::lock_guard lock(mu);
    if (!s->open) return;
    s->open = false;
    while (!s->subs.empty()) {
      const ChannelId ch = s->subs.begin()->second.channel;
      if (end_subscription_locked(*s, s->subs.begin())) lasts.push_back(ch);
    }
    s->control.clear();
    ++totals.clients_closed;
    if (s->overflow) ++totals.closed_overflow;
    sessions.erase(s->id);
  }
  log::info("view", "client " + std::to_string(s->id) + " (" + s->peer + ") gone: " + why);
  beast::error_code ignored;
  s->ws.next_layer().socket().shutdown(tcp::socket::shutdown_both, ignored);
  s->ws.next_layer().socket().close(ignored);
  notify({}, lasts);
}

// ------------------------------------------------------------------------------------------------
// Writing

void Server::Impl::pump(const std::shared_ptr<Session>& s) {
  enum class What { kNone, kText, kTime, kData } what = What::kNone;
  {
    std::lock_guard lock(mu);
    s->pump_posted = false;
    if (s->writing || !s->open) return;
    if (s->closing) {
      s->writing = true;  // the close is the last frame
      s->ws.async_close(websocket::close_code::going_away,
                        [self = this, s](beast::error_code) { self->close_session(s, "server stopping"); });
      return;
    }
    if (!s->control.empty()) {
      s->text_out = std::move(s->control.front());
      s->control.pop_front();
      what = What::kText;
    } else if (s->time_pending) {
      s->time_out = time_message(*s->time_pending);
      s->time_pending.reset();
      what = What::kTime;
    } else if (Subscription* next = s->oldest_data()) {
      s->data_out = next->queue.pop();
      ++next->sent;
      what = What::kData;
    }
    if (what == What::kNone) return;
    s->writing = true;
  }
  auto done = [self = this, s, what](beast::error_code ec, std::size_t bytes) {
    {
      std::lock_guard lock(self->mu);
      s->writing = false;
      if (what == What::kData) {
        ++s->messages_sent;
        s->bytes_sent += bytes;
        s->data_out.payload.reset();
      }
    }
    if (ec) {
      self->close_session(s, "write: " + ec.message());
      return;
    }
    self->pump(s);
  };
  if (what == What::kText) {
    s->ws.text(true);
    s->ws.async_write(net::buffer(s->text_out), done);
  } else if (what == What::kTime) {
    s->ws.binary(true);
    s->ws.async_write(net::buffer(s->time_out), done);
  } else {
    s->ws.binary(true);
    const std::array<net::const_buffer, 2> bufs{net::buffer(s->data_out.header),
                                                 net::buffer(*s->data_out.payload)};
    s->ws.async_write(bufs, done);
  }
}

void Server::Impl::tick_time() {
  time_timer.expires_after(std::chrono::milliseconds(options.time_interval_ms));
  time_timer.async_wait([self = this](beast::error_code ec) {
    if (ec || self->stopping) return;
    const auto now = static_cast<std::uint64_t>(vehicle_now_ns());
    {
      std::lock_guard lock(self->mu);
      for (auto& [id, s] : self->sessions) {
        s->time_pending = now;  // only the latest: a slow client does not pile them up
        self->schedule_locked(s);
      }
    }
    self->tick_time();
  });
}

void Server::Impl::tick_report() {
  report_timer.expires_after(std::chrono::seconds(1));
  report_timer.async_wait([self = this](beast::error_code ec) {
    if (ec || self->stopping) return;
    {
      std::lock_guard lock(self->mu);
      for (auto& [id, s] : self->sessions)
        for (auto& [sub, state] : s->subs) {
          const std::uint64_t d = state.queue.dropped();
          if (d == state.reported_dropped) continue;
          const auto c = self->channels.find(state.channel);
          const std::string topic = c != self->channels.end() ? c->second.spec.topic : "?";
          self->control_locked(s, status_json(StatusLevel::kWarning,
                                              "slow client: " + std::to_string(d - state.reported_dropped) +
                                                  " messages on " + topic +
                                                  " dropped in the last second (the newest " +
                                                  std::to_string(state.queue.limits().min_items) +
                                                  " or more are kept); " +
                                                  std::to_string(d) + " in all"));
          state.reported_dropped = d;
        }
    }
    self->tick_report();
  });
}

// ------------------------------------------------------------------------------------------------
// Server

Server::Server(ServerOptions options) : impl_(std::make_unique<Impl>(std::move(options))) {
  auto& im = *impl_;
  beast::error_code ec;
  const auto addr = net::ip::make_address(im.options.address, ec);
  if (ec) throw std::invalid_argument("rig view: '" + im.options.address + "' is not an IP address");
  const tcp::endpoint ep(addr, im.options.port);
  const std::string where = im.options.address + ":" + std::to_string(im.options.port);
  auto fail = [&](const char* what) {
    throw std::system_error(ec.value(), std::generic_category(), std::string("cannot ") + what + " " + where);
  };
  if (im.acceptor.open(ep.protocol(), ec); ec) fail("open a socket for");
  // A restarted server takes its port back at once (TIME_WAIT of the last run's connections).
  if (im.acceptor.set_option(net::socket_base::reuse_address(true), ec); ec) fail("set SO_REUSEADDR on");
  if (im.acceptor.bind(ep, ec); ec) fail("listen on");
  if (im.acceptor.listen(net::socket_base::max_listen_connections, ec); ec) fail("listen on");
  im.port = im.acceptor.local_endpoint().port();
  im.session_id = std::to_string(vehicle_now_ns());
}

Server::~Server() { stop(); }

std::uint16_t Server::port() const noexcept { return impl_->port; }
const ServerOptions& Server::options() const noexcept { return impl_->options; }

void Server::start(Callbacks callbacks) {
  auto& im = *impl_;
  if (im.thread.joinable()) return;
  im.callbacks = std::move(callbacks);
  im.accept();
  if (im.options.time_interval_ms > 0) im.tick_time();
  im.tick_report();
  im.thread = std::thread([self = impl_.get()] {
    try {
      self->ioc.run();
    } catch (const std::exception& e) {  // a callback threw: the server cannot go on consistently
      log::error("view", std::string("I/O thread stopped: ") + e.what());
    }
  });
}

void Server::stop() {
  auto& im = *impl_;
  if (!im.thread.joinable() || im.stopping.exchange(true)) return;
  net::post(im.ioc, [self = impl_.get()] {
    beast::error_code ignored;
    self->acceptor.close(ignored);
    self->time_timer.cancel();
    self->report_timer.cancel();
    std::vector<std::shared_ptr<Session>> open;
    {
      std::lock_guard lock(self->mu);
      for (auto& [id, s] : self->sessions) open.push_back(s);
    }
    // A client that reads gets a WebSocket close (going away), after the frame it is being sent;
    // one that does not (that write never completes) has its socket closed when the grace ends.
    for (auto& s : open) {
      {
        std::lock_guard lock(self->mu);
        s->closing = true;
      }
      self->pump(s);
    }
    auto grace = std::make_shared<net::steady_timer>(self->ioc, std::chrono::milliseconds(500));
    grace->async_wait([self, grace, open](beast::error_code) {
      for (auto& s : open) self->close_session(s, "server stopping");
      self->ioc.stop();
    });
  });
  im.thread.join();
}

ChannelId Server::add_channel(ChannelSpec spec) {
  auto& im = *impl_;
  std::lock_guard lock(im.mu);
  const ChannelId id = im.next_channel++;
  Channel c{id, std::move(spec)};
  const std::string msg = advertise_json({c});
  im.channels.emplace(id, std::move(c));
  for (auto& [sid, s] : im.sessions) im.control_locked(s, msg);
  return id;
}

void Server::remove_channel(ChannelId id) {
  auto& im = *impl_;
  std::lock_guard lock(im.mu);
  if (im.channels.erase(id) == 0) return;
  const std::string msg = unadvertise_json({id});
  for (auto& [sid, s] : im.sessions) {
    for (auto it = s->subs.begin(); it != s->subs.end();) {
      auto next = std::next(it);
      if (it->second.channel == id) im.end_subscription_locked(*s, it);
      it = next;
    }
    im.control_locked(s, msg);
  }
  im.subscribers.erase(id);
}

bool Server::has_subscribers(ChannelId id) const {
  std::lock_guard lock(impl_->mu);
  return impl_->subscribers.count(id) != 0;
}

void Server::publish(ChannelId channel, std::uint64_t receive_ns,
                     std::span<const std::span<const std::uint8_t>> pieces) {
  auto& im = *impl_;
  if (!has_subscribers(channel)) return;
  // The one copy, outside the lock: a 7 MB image takes a millisecond to copy.
  std::size_t size = 0;
  for (const auto& p : pieces) size += p.size();
  auto bytes = std::make_shared<std::vector<std::uint8_t>>();
  bytes->reserve(size);
  for (const auto& p : pieces) bytes->insert(bytes->end(), p.begin(), p.end());
  std::shared_ptr<const std::vector<std::uint8_t>> payload = std::move(bytes);
  std::lock_guard lock(im.mu);
  ++im.totals.published;
  const std::uint64_t seq = ++im.seq;
  for (auto& [sid, s] : im.sessions)
    for (auto& [sub, state] : s->subs) {
      if (state.channel != channel) continue;
      im.totals.dropped += state.queue.push(QueuedMessage{seq, message_data_header(sub, receive_ns), payload}, size);
      im.schedule_locked(s);
    }
}

void Server::broadcast_status(StatusLevel level, const std::string& message) {
  auto& im = *impl_;
  std::lock_guard lock(im.mu);
  const std::string msg = status_json(level, message);
  for (auto& [sid, s] : im.sessions) im.control_locked(s, msg);
}

ServerStats Server::stats() const {
  const auto& im = *impl_;
  std::lock_guard lock(im.mu);
  ServerStats st = im.totals;
  st.channels = im.channels.size();
  for (const auto& [sid, s] : im.sessions) {
    ClientStats c;
    c.id = s->id;
    c.peer = s->peer;
    c.messages_sent = s->messages_sent;
    c.bytes_sent = s->bytes_sent;
    c.protocol_errors = s->protocol_errors;
    c.dropped = s->past_dropped;
    for (const auto& [sub, state] : s->subs) {
      SubscriptionStats ss;
      ss.id = sub;
      ss.channel = state.channel;
      const auto ch = im.channels.find(state.channel);
      if (ch != im.channels.end()) ss.topic = ch->second.spec.topic;
      ss.sent = state.sent;
      ss.dropped = state.queue.dropped();
      ss.queued = state.queue.size();
      c.dropped += ss.dropped;
      c.subscriptions.push_back(std::move(ss));
    }
    st.clients.push_back(std::move(c));
  }
  return st;
}

}  // namespace sensor_rig::view
