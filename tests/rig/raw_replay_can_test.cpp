// The CAN bus's raw channel (issue 29): the frames `rig record --raw` wrote are the bus's, one for one,
// and a recorded drive (a file, a split folder, one with a cut file) replayed into a bridge gives
// the recorded /vehicle/state. Shares raw_replay_test.cpp's fixture (raw_replay_fixture.hpp).
#include "raw_replay_fixture.hpp"

namespace sensor_rig::rig {
namespace {

using namespace raw_replay;

// The CAN bus's raw channel: the mock ECU logs every frame on the bus (candump -L); the frames the
// bridge received and `rig record --raw` wrote, decoded by @mcap/core, are the ECU's frames of the
// log one for one, in order, from the first recorded to the last (none lost, none made up).
TEST_F(RawReplay, CanFramesAreTheBusFramesOneForOne) {
  const std::string bus = (dir_.path / "bus").string();  // in the test's folder: no socket file left elsewhere
  const std::string log = (dir_.path / "bus.log").string();
  const std::string file = (dir_.path / "can.mcap").string();
  test::RigChild ecu({"mock", "paravan", "--transport", "unix-listen:" + bus, "--log", log, "--duration", "60"},
                     (dir_.path / "ecu.out").string(), (dir_.path / "ecu.err").string());
  ASSERT_TRUE(ecu.started());
  // The ECU listening (its start line) before the bridge connects: the bridge does not retry.
  ASSERT_TRUE(says(ecu, "mock paravan:")) << ecu.err();
  test::RigChild bridge({"dbw", "bridge", "--transport", "unix:" + bus, "--domain", std::to_string(domain_), "--duration", "60"},
                        (dir_.path / "bridge.out").string(), (dir_.path / "bridge.err").string());
  ASSERT_TRUE(bridge.started());
  // The bridge up (its start line) before the recorder's 3 s begin: a loaded host starts it slowly.
  ASSERT_TRUE(says(bridge, "dbw bridge:")) << bridge.err();
  test::RigChild rec = record({"--raw"}, file, 6.0);
  ASSERT_EQ(rec.wait(60'000), 0) << rec.err();
  bridge.signal_and_wait(SIGINT, 20'000);
  ecu.signal_and_wait(SIGINT, 20'000);
  const auto summary = rec.summary();
  ASSERT_TRUE(summary.contains("topics") && summary["topics"].contains("/vehicle/can/frames")) << rec.out() << rec.err();
  EXPECT_EQ(summary["topics"]["/vehicle/can/frames"]["queue_full"], 0);

  const auto j = test::mcap_dump(file);
  ASSERT_FALSE(j.contains("error")) << j.dump().substr(0, 2000);
  EXPECT_EQ(j["channels"]["/vehicle/can/frames"]["schema"], "sensor_rig_msgs/msg/CanFrame");
  std::vector<std::string> recorded;  // "ID#DATA" as candump writes them
  std::set<std::string> ids;
  for (const auto& m : j["messages"]) {
    if (m["topic"] != "/vehicle/can/frames") continue;
    char id[16];
    std::snprintf(id, sizeof id, m["is_extended"].get<bool>() ? "%08X" : "%03X", m["id"].get<unsigned>());
    std::string text = std::string(id) + "#";
    for (const auto& b : m["data"]) {
      char hex[3];
      std::snprintf(hex, sizeof hex, "%02X", b.get<unsigned>());
      text += hex;
    }
    ids.insert(id);
    recorded.push_back(text);
    EXPECT_FALSE(m["frame_id"].get<std::string>().empty());
  }
  ASSERT_GE(recorded.size(), 100u);  // the ECU's cyclic frames, ~250 a second
  std::vector<std::string> sent;  // the log's frames of those ids
  std::istringstream in(test::read_file(log));
  for (std::string line; std::getline(in, line);) {
    const auto sp = line.rfind(' ');
    const std::string frame = line.substr(sp + 1);
    if (ids.count(frame.substr(0, frame.find('#'))) != 0) sent.push_back(frame);
  }
  const auto first = std::search(sent.begin(), sent.end(), recorded.begin(), recorded.begin() + 8);
  ASSERT_NE(first, sent.end()) << "the first recorded frames are not in the bus log: " << recorded.front();
  ASSERT_GE(static_cast<std::size_t>(sent.end() - first), recorded.size())
      << "log " << sent.size() << " frames of those ids, from the first recorded " << (sent.end() - first) << "; recorded "
      << recorded.size() << "; ecu: " << ecu.err();
  EXPECT_TRUE(std::equal(recorded.begin(), recorded.end(), first)) << "recorded frames differ from the bus log";
}

// A drive on the desk: the mock ECU, a bridge, `rig dbw send` steering and accelerating (speed,
// wheels, yaw rate and the angle change from state to state); /vehicle/state and the raw CAN channel
// recorded; then the raw channel replayed into a second bridge (`--transport mcap:...`) whose
// /vehicle/state is recorded again.
class CanDriveReplay : public RawReplay {
 protected:
  struct State {
    std::string stamp;
    nlohmann::json values;
    bool operator==(const State&) const = default;
  };

  void record_drive(const std::string& out, const std::vector<std::string>& extra, double seconds) {
    const std::string bus = (dir_.path / "bus").string(), dom = std::to_string(domain_);
    test::RigChild ecu({"mock", "paravan", "--transport", "unix-listen:" + bus, "--duration", "60"},
                       (dir_.path / "ecu.out").string(), (dir_.path / "ecu.err").string());
    ASSERT_TRUE(says(ecu, "mock paravan:")) << ecu.err();
    test::RigChild bridge({"dbw", "bridge", "--transport", "unix:" + bus, "--domain", dom, "--duration", "60"},
                          (dir_.path / "bridge.out").string(), (dir_.path / "bridge.err").string());
    ASSERT_TRUE(says(bridge, "dbw bridge:")) << bridge.err();
    test::RigChild send({"dbw", "send", "--domain", dom, "--enable", "--steer", "0.1", "--throttle", "0.4", "--gear", "4",
                         "--rate", "50", "--duration", "60"},
                        (dir_.path / "send.out").string(), (dir_.path / "send.err").string());
    ASSERT_TRUE(send.started());
    std::vector<std::string> topics{"/vehicle/state", "/vehicle/can/frames"};
    topics.insert(topics.end(), extra.begin(), extra.end());
    test::RigChild rec = record(topics, out, seconds);
    ASSERT_EQ(rec.wait(60'000), 0) << rec.err();
    send.signal_and_wait(SIGINT, 20'000);
    bridge.signal_and_wait(SIGINT, 20'000);
    ecu.signal_and_wait(SIGINT, 20'000);
  }

  // The replaying bridge's stderr, once its transport closed at the recording's end; its states in
  // `states`. Its first frame 3 s after it opens the recording (`spec` "mcap:PATH@RATE,3"): the
  // recorder matched first.
  std::string replay(const std::string& spec, std::vector<State>& states) {
    const std::string out = (dir_.path / "replayed.mcap").string();
    const std::string err = replay_into(spec, out);
    std::vector<std::uint64_t> frames;
    read_drive({out}, states, frames);
    return err;
  }

  std::string replay_into(const std::string& spec, const std::string& out) {
    test::RigChild rec = record({"/vehicle/state"}, out, 60.0);
    EXPECT_TRUE(rec.started());
    test::RigChild bridge({"dbw", "bridge", "--transport", spec, "--domain", std::to_string(domain_), "--duration", "60"},
                          out + ".bridge.out", out + ".bridge.err");
    // The transport closes at the recording's end (the bridge logs it): then every state is out.
    if (!says(bridge, "dbw bridge:") || !says(bridge, "CAN transport closed")) {
      ADD_FAILURE() << bridge.err();
      return bridge.err();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the last states through DDS to the recorder
    bridge.signal_and_wait(SIGINT, 20'000);
    EXPECT_EQ(rec.signal_and_wait(SIGINT, 20'000), 0) << rec.err();
    return bridge.err();
  }

  // The states and CAN frame stamps of a recording's files (in order), read by @mcap/core.
  static void read_drive(const std::vector<std::string>& files, std::vector<State>& states, std::vector<std::uint64_t>& frames) {
    for (const auto& f : files) {
      const auto j = test::mcap_dump(f);
      ASSERT_FALSE(j.contains("error")) << f << ": " << j.dump().substr(0, 2000);
      for (const auto& m : j["messages"]) {
        if (m["topic"] == "/vehicle/state")
          states.push_back({m["stamp_ns"].get<std::string>(), {m["speed"], m["wheels"], m["steering_angle"], m["yaw_rate"], m["gear"]}});
        else if (m["topic"] == "/vehicle/can/frames")
          frames.push_back(std::stoull(m["stamp_ns"].get<std::string>()));
      }
    }
  }

  // Over the window the live recording's frames and states both cover: the replayed states are the
  // live ones whose frame is `kept` (by stamp: all, when null), same stamps, values and order, none
  // added. But for 100 ms after lost frames: the bridge's E2E check refuses the first frame of each
  // id whose alive counter jumped too far (kWrongSequence) and resynchronises on it, so a state
  // there may be missing or carry a value of before the loss (its stamp is still a recorded one).
  static void expect_replayed(const std::vector<State>& live, const std::vector<std::uint64_t>& frames,
                              const std::vector<State>& replayed, const std::set<std::uint64_t>* kept = nullptr) {
    ASSERT_GE(live.size(), 100u);  // feedback at 100 Hz
    ASSERT_GE(frames.size(), 300u);
    const std::uint64_t lo = std::max<std::uint64_t>(*std::min_element(frames.begin(), frames.end()), std::stoull(live.front().stamp));
    const std::uint64_t hi = std::min<std::uint64_t>(*std::max_element(frames.begin(), frames.end()), std::stoull(live.back().stamp));
    std::vector<State> want, got;
    std::set<std::string> settling;  // the states of the 100 ms after lost frames
    bool lost = false;
    std::uint64_t settled = 0;
    for (const auto& s : live) {
      const auto t = std::stoull(s.stamp);
      if (t < lo || t > hi) continue;
      if (kept != nullptr && kept->count(t) == 0) {
        lost = true;
        continue;
      }
      if (std::exchange(lost, false)) settled = t + 100'000'000;
      if (t < settled) settling.insert(s.stamp);
      want.push_back(s);
    }
    for (const auto& s : replayed)
      if (const auto t = std::stoull(s.stamp); t >= lo && t <= hi) got.push_back(s);
    ASSERT_GE(want.size(), 100u);
    std::set<std::string> values;
    for (const auto& s : want) values.insert(s.values.dump());
    EXPECT_GE(values.size(), want.size() / 2) << "the live states hardly changed: the test would not see values mixed up";
    std::size_t g = 0, refused = 0;
    for (const auto& w : want) {
      const bool settles = settling.count(w.stamp) != 0;
      if (g < got.size() && (got[g] == w || (settles && got[g].stamp == w.stamp))) {
        ++g;
      } else if (settles) {
        ++refused;
      } else {
        ADD_FAILURE() << "recorded state " << w.stamp << " " << w.values.dump() << ": replayed "
                      << (g < got.size() ? got[g].stamp + " " + got[g].values.dump() : std::string("nothing"));
        break;
      }
    }
    EXPECT_EQ(g, got.size()) << "replayed states that were not recorded";
    std::printf("live: %zu states, %zu frames; window %zu states (%zu settling after lost frames); replayed %zu states, %zu "
                "in the window (%zu of the settling missing)\n", live.size(), frames.size(), want.size(), settling.size(),
                replayed.size(), got.size(), refused);
  }

  // A split recording: a file every 0.8 s, 16 KiB chunks.
  inline static const std::vector<std::string> kSplit{"--split-s", "0.8", "--chunk-kb", "16"};

  struct Drive {
    std::string path;                  // the file, or the split recording's folder
    std::vector<std::string> files;    // the files, in order
    std::vector<State> states;         // /vehicle/state
    std::vector<std::uint64_t> frames;  // the CAN frames' stamps
  };
  // A live drive recorded to `out` for `seconds` (`extra`: kSplit for a folder), read by @mcap/core.
  Drive drive(const std::string& out, const std::vector<std::string>& extra, double seconds) {
    Drive d{out, {}, {}, {}};
    record_drive(out, extra, seconds);
    if (::testing::Test::HasFatalFailure()) return d;
    d.files = extra.empty() ? std::vector<std::string>{out} : split_files(out);
    read_drive(d.files, d.states, d.frames);
    return d;
  }
};

// `--transport mcap:FILE`: over the window both live recordings cover, the replayed states are the
// recorded ones (each stamped with its frame's recorded kernel receive time).
TEST_F(CanDriveReplay, CanChannelReplayedIntoABridgeGivesTheRecordedVehicleStates) {
  const Drive d = drive((dir_.path / "live.mcap").string(), {}, 3.0);
  if (HasFatalFailure()) return;
  std::vector<State> again;
  const std::string err = replay("mcap:" + d.path + "@2,3", again);
  expect_replayed(d.states, d.frames, again);
  EXPECT_EQ(err.find("offset"), std::string::npos) << err;
}

// `--transport mcap:FOLDER` (issue 29): a split recording (`rig record --split-s 0.8`, several files)
// replays as one drive, file after file in metadata.yaml's order, nothing lost or doubled at the
// seams. At rate 4, so that the drive and its replay take ~9 s.
TEST_F(CanDriveReplay, SplitRecordingFolderReplaysAsOneDrive) {
  const Drive d = drive((dir_.path / "live").string(), kSplit, 2.5);
  if (HasFatalFailure()) return;
  ASSERT_GE(d.files.size(), 3u) << "a file every 0.8 s for 2.5 s";
  std::printf("a split recording of %zu files\n", d.files.size());
  std::vector<State> again;
  const std::string err = replay("mcap:" + d.path + "@4,3", again);
  expect_replayed(d.states, d.frames, again);
  EXPECT_EQ(err.find("offset"), std::string::npos) << err;
}

// The same with its second file cut to two thirds (small chunks: part of it stays readable): the
// states of every frame still intact (our reader's reading of each file) replay, the later files'
// too, and the bridge names the cut file's place when the transport closes.
TEST_F(CanDriveReplay, SplitRecordingWithACutFileReplaysWhatIsIntact) {
  const Drive d = drive((dir_.path / "live").string(), kSplit, 2.5);
  if (HasFatalFailure()) return;
  ASSERT_GE(d.files.size(), 3u) << "a file every 0.8 s for 2.5 s";
  const std::string& cut = d.files[1];
  std::filesystem::resize_file(cut, std::filesystem::file_size(cut) * 2 / 3);
  std::set<std::uint64_t> intact;
  std::size_t cut_file_frames = 0;
  for (const auto& f : d.files) {
    record::McapReader r(f);
    dds::CanFrameView v;
    r.for_each_message([&](const record::McapMessage& m) {
      const auto body = dds::cdr_body(m.data);
      if (r.channels().at(m.channel_id).topic == "/vehicle/can/frames" && body && dds::parse_cdr(*body, v) == dds::CdrStatus::kOk) {
        intact.insert(static_cast<std::uint64_t>(v.header.sec) * 1'000'000'000 + v.header.nanosec);
        cut_file_frames += f == cut ? 1 : 0;
      }
      return true;
    });
  }
  ASSERT_LT(intact.size(), d.frames.size());
  ASSERT_GT(cut_file_frames, 0u) << "the cut should keep part of the file";
  std::vector<State> again;
  const std::string err = replay("mcap:" + d.path + "@4,3", again);
  expect_replayed(d.states, d.frames, again, &intact);
  const auto at = err.find(cut + ": ");
  EXPECT_NE(at, std::string::npos) << err;
  EXPECT_NE(err.find("offset", at), std::string::npos) << err;
}

}  // namespace
}  // namespace sensor_rig::rig
