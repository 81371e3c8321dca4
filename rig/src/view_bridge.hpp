#pragma once
// `rig view`: the rig's DDS topics on a Foxglove WebSocket server (view/server.hpp). Discovery
// (dds::DiscoveryReader) tells which topics have writers: each topic of a type the rig knows
// (dds::find_type) is advertised with its ros2msg schema while it has at least one writer, and
// unadvertised when its last writer goes. A raw reader (dds::RawReader) exists only while some
// client subscribes to the topic; its CDR bytes go to the clients unchanged, stamped with the time
// they were taken.
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "sensor_rig/dds/discovery.hpp"
#include "sensor_rig/dds/participant.hpp"
#include "sensor_rig/dds/raw_topic.hpp"
#include "sensor_rig/dds/waitset.hpp"
#include "sensor_rig/view/server.hpp"

namespace sensor_rig::rig {

struct ViewOptions {
  dds::DomainConfig dds;
  view::ServerOptions server;
  double duration_s = 0;        // 0: until SIGINT/SIGTERM
  double stats_interval_s = 5;  // a JSON stats line on stdout this often (0: only at the end)
  // Keep-last depth of each raw reader: the bridge takes at once, but a burst (/rig/stamps: one per
  // sensor at the same instant) must not overwrite samples before it wakes.
  int reader_depth = 16;
};

// Runs until shutdown (or the duration); exit code (0, or 1 when the server could not start).
int run_view(const ViewOptions& options);

class ViewBridge {
 public:
  ViewBridge(const dds::Participant& participant, view::Server& server, int reader_depth);
  ViewBridge(const ViewBridge&) = delete;
  ViewBridge& operator=(const ViewBridge&) = delete;
  ~ViewBridge();

  // For the server's callbacks (its I/O thread): queued, handled by poll() on the bridge's thread.
  void request_reader(view::ChannelId channel, bool wanted);
  // Waits up to timeout_ns for discovery, requests and samples, and handles them.
  void poll(std::int64_t timeout_ns);
  // Topics, readers, unknown types, DDS-side losses.
  [[nodiscard]] nlohmann::json stats();

 private:
  struct Topic {
    std::string ros_name;
    const dds::RegisteredType* type = nullptr;
    std::set<std::string> writers;            // writer GUIDs alive
    std::set<std::string> best_effort_writers;  // of those
    std::set<std::string> transient_writers;    // transient-local ones
    view::ChannelId channel = 0;              // 0: not advertised
    std::unique_ptr<dds::RawReader> reader;   // while a client subscribes
    std::int64_t tag = 0;
    std::uint64_t forwarded = 0;
  };

  void on_publication(const dds::Publication& pub);
  void open_reader(const std::string& dds_topic, Topic& t);
  void close_reader(Topic& t);
  void drain(Topic& t);

  const dds::Participant& participant_;
  view::Server& server_;
  int reader_depth_;
  dds::WaitSet waitset_;
  dds::DiscoveryReader discovery_;
  std::map<std::string, Topic> topics_;               // by DDS topic name
  std::map<std::string, std::string> writer_topic_;   // writer GUID -> DDS topic name
  std::map<view::ChannelId, std::string> channel_topic_;
  std::map<std::int64_t, std::string> tag_topic_;
  std::map<std::string, std::string> unknown_;        // DDS topic -> its type, unknown to the rig
  std::set<std::string> type_conflicts_;              // topics whose writers disagree on the type
  std::int64_t next_tag_ = 16;
  std::uint64_t lost_ = 0, rejected_ = 0, malformed_ = 0;  // of readers already closed
  std::uint64_t readers_opened_ = 0;

  std::mutex requests_mu_;
  std::vector<std::pair<view::ChannelId, bool>> requests_;
  std::vector<std::int64_t> triggered_;
};

}  // namespace sensor_rig::rig
