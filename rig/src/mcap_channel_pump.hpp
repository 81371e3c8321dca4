#pragma once
// One raw channel of a `rig record --raw` recording, read ahead on a thread of its own: the replays
// (McapCanLog: CAN frames; McapPacketStream: LIDAR datagrams) only pop what it decoded. The thread
// walks the channel's messages file after file (a split recording's files as one stream; channels
// declared inside later chunks too), decodes each CDR sample into items and queues them up to
// `ahead` (in the items' cost: frames, bytes). A damaged file (cut, corrupt chunk, undecodable
// message, a file of a folder that does not open) gives what is intact; error() names each place.
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "recording_files.hpp"
#include "sensor_rig/dds/cdr_view.hpp"
#include "sensor_rig/record/mcap_reader.hpp"

namespace sensor_rig::rig {

// Which channel of a file to read, and how far ahead.
struct McapChannelSpec {
  std::string schema;  // "sensor_rig_msgs/msg/CanFrame"; message encoding cdr
  // The topic to read among the file's topics of that schema, "" when none fits; then `none` says
  // why (the exception's text, after "FILE: ").
  std::function<std::string(const std::vector<std::string>& topics)> pick;
  std::function<std::string(const std::vector<std::string>& topics)> none;
  std::string log_tag;    // the problems found on opening are logged as warnings under it
  std::size_t ahead = 0;  // what the reader thread queues at most, in the items' cost
};

// Thrown when a file opens but has no channel the spec picks (the text names the file and why).
class McapNoChannel : public std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A file opened and its channel found (in the summary, else in the chunks).
class McapChannelFile {
 public:
  // Throws std::runtime_error when the file is not MCAP, McapNoChannel when it has no channel the
  // spec picks.
  McapChannelFile(const std::string& path, const McapChannelSpec& spec);
  [[nodiscard]] const std::string& topic() const noexcept { return topic_; }
  // The channel's messages in file order; fn returns false to stop.
  void for_each(const std::function<bool(const record::McapMessage&)>& fn);
  // The reader's problems (damaged places), each after `where`, "; "-joined.
  [[nodiscard]] std::string problems(const std::string& where) const;

 private:
  [[nodiscard]] bool ours(std::uint16_t channel_id) const;

  std::unique_ptr<record::McapReader> reader_;
  std::string schema_, topic_;
};

// "; "-joins b to a.
void append_problem(std::string& a, const std::string& b);

// The first of a recording's files that holds the channel. A split recording's first files may
// hold none of it (a channel is written into a file with its first message: a LIDAR that came up
// after the first split): those are skipped, and those that do not open are named in `damaged`.
struct FirstChannelFile {
  std::size_t index = 0;
  McapChannelFile file;
  std::string damaged;
};
// Throws the first file's error when no file holds the channel.
FirstChannelFile open_first_channel_file(const std::vector<std::string>& files, const McapChannelSpec& spec);

template <class View, class Item>
class McapChannelPump {
 public:
  // Queues one item; false when the pump is closing (the decoder should return).
  using Push = std::function<bool(Item&&)>;
  // One sample of the channel: "" once its items are pushed, else why it is not one (skipped).
  using Decode = std::function<std::string(const View&, const Push&)>;
  using Cost = std::function<std::size_t(const Item&)>;

  // The files in order (one at least); the first holding the channel is opened here (its topic is
  // the channel's in the others), the later ones by the thread.
  McapChannelPump(std::vector<std::string> files, McapChannelSpec spec, Decode decode, Cost cost)
      : spec_(std::move(spec)), files_(std::move(files)), first_(open_first_channel_file(files_, spec_)),
        decode_(std::move(decode)), cost_(std::move(cost)) {
    start();
  }
  ~McapChannelPump() { stop(); }
  McapChannelPump(const McapChannelPump&) = delete;
  McapChannelPump& operator=(const McapChannelPump&) = delete;

  [[nodiscard]] const std::string& topic() const noexcept { return first_.file.topic(); }

  // The next item; nullopt at the end.
  std::optional<Item> next() {
    std::unique_lock lock(mu_);
    cv_.wait(lock, [&] { return !queue_.empty() || done_; });
    if (queue_.empty()) return std::nullopt;
    Item item = std::move(queue_.front());
    queue_.pop_front();
    queued_ -= cost_(item);
    cv_.notify_all();
    return item;
  }

  // Back to the first message (a new pass, its problems counted afresh).
  void rewind() {
    stop();
    start();
  }

  [[nodiscard]] std::uint64_t undecodable() const {
    std::lock_guard lock(mu_);
    return undecodable_;
  }

  // Once the end is reached: the damaged places and skipped messages ("" if none).
  [[nodiscard]] std::string error() const {
    std::lock_guard lock(mu_);
    return done_ ? problems_ : std::string{};
  }

 private:
  void start() {
    {
      std::lock_guard lock(mu_);
      queue_.clear();
      queued_ = 0;
      undecodable_ = 0;
      done_ = stop_ = false;
      problems_.clear();
    }
    thread_ = std::thread([this] { produce(); });
  }

  void stop() {
    {
      std::lock_guard lock(mu_);
      stop_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

  void produce() {
    const Push push = [this](Item&& item) {
      std::unique_lock lock(mu_);
      cv_.wait(lock, [&] { return stop_ || queued_ < spec_.ahead; });
      if (stop_) return false;
      queued_ += cost_(item);
      queue_.push_back(std::move(item));
      cv_.notify_all();
      return true;
    };
    const std::string sample = spec_.schema.substr(spec_.schema.rfind('/') + 1);
    View view;
    std::string damaged = first_.damaged, skipped;
    bool going = true;
    for (std::size_t i = first_.index; i < files_.size() && going; ++i) {
      // Several files: each place names its file. A later file is opened here, and one without
      // the channel (a split file of a time nothing was on it) is no damage.
      const std::string where = files_.size() > 1 ? files_[i] + ": " : "";
      std::optional<McapChannelFile> later;
      if (i > first_.index) {
        try {
          later.emplace(files_[i], McapChannelSpec{spec_.schema, [&](const auto&) { return topic(); }, {}, spec_.log_tag, 0});
        } catch (const std::exception& e) {
          append_problem(damaged, e.what());
          continue;
        }
      }
      McapChannelFile& file = later ? *later : first_.file;
      file.for_each([&](const record::McapMessage& m) {
        const auto body = dds::cdr_body(m.data);
        const dds::CdrStatus st = body ? dds::parse_cdr(*body, view) : dds::CdrStatus::kBadEncapsulation;
        const std::string why = st == dds::CdrStatus::kOk ? decode_(view, push) : dds::to_string(st);
        std::lock_guard lock(mu_);
        if (!why.empty() && undecodable_++ == 0)
          skipped = where + "message " + std::to_string(m.sequence) + " of " + topic() + " is not a " + sample +
                    " sample (" + why + "): skipped";
        going = !stop_;
        return going;
      });
      append_problem(damaged, file.problems(where));
    }
    std::lock_guard lock(mu_);
    if (undecodable_ > 1) skipped += " (" + std::to_string(undecodable_) + " such messages)";
    append_problem(problems_, damaged);
    append_problem(problems_, skipped);
    done_ = true;
    cv_.notify_all();
  }

  const McapChannelSpec spec_;
  const std::vector<std::string> files_;
  FirstChannelFile first_;  // opened first: its channel names the topic; read by the thread only while it runs
  const Decode decode_;
  const Cost cost_;
  std::thread thread_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<Item> queue_;             // under mu_
  std::size_t queued_ = 0;             // under mu_: the queue's cost
  std::uint64_t undecodable_ = 0;      // under mu_
  bool done_ = false, stop_ = false;   // under mu_
  std::string problems_;               // under mu_
};

}  // namespace sensor_rig::rig
