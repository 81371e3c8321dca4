// Raw LIDAR channels (issue 29): `rig up` runs a synthetic VLP-32C through its driver while `rig
// record --raw` records its packets and its scans; then `rig up` replays the recorded packets
// through the same driver (mock: {kind: mcap}) while another recorder takes the scans. Every live
// scan that lies wholly inside the raw recording must come out of the replay with the same stamp
// (sensor time, GPRMC hour, no clock correction: the packets' own) and the same point count, and
// the replay has no other scan in that window. The raw channel is also read by @mcap/core
// (tests/js/mcap_dump.mjs); a cut and a corrupted recording replay what is intact and say where not.
// A split recording's folder replays as one stream (LidarSplitReplay; CanDriveReplay for the CAN bus);
// what its files lost is held against the live mock's truth record (a packet sent and not recorded),
// never against time without packets (the mock, SCHED_FIFO or not, pauses >5 ms on a loaded host).
#include "raw_replay_fixture.hpp"

namespace sensor_rig::rig {
namespace {

using namespace raw_replay;

TEST_F(RawReplay, ScansReplayedThroughTheDriverEqualTheLiveOnes) {
  const std::string live = (dir_.path / "live.mcap").string();
  const std::string replayed = (dir_.path / "replayed.mcap").string();
  {
    test::RigChild up({"up", config("live.yaml", "{kind: synthetic, rpm: 600}"), "--duration", "60"},
                      (dir_.path / "up_live.out").string(), (dir_.path / "up_live.err").string());
    ASSERT_TRUE(up.started());
    // --raw: every topic, the raw channel included (its driver publishes it only while recorded).
    test::RigChild rec = record({"--raw"}, live, 5.0);
    ASSERT_EQ(rec.wait(90'000), 0) << rec.err();
    const auto s = rec.summary();
    ASSERT_GT(s["topics"]["/sensors/lidar/raw29/packets"]["written"].get<int>(), 0) << rec.out() << rec.err();
    EXPECT_EQ(s["drops"]["queue_full"], 0);
    up.signal_and_wait(SIGINT, 20'000);
  }
  const Recorded l = read_recording(live, "raw29");
  ASSERT_TRUE(l.problems.empty());
  ASSERT_GT(l.data_packets, 1000u);  // ~1500 a second
  EXPECT_GT(l.position_packets, 0u);  // the second port's too: the replay needs their GPRMC hour

  // The live scans wholly inside the raw recording: their every packet was recorded.
  std::map<Nanos, std::uint32_t> inside;
  for (const auto& [stamp, points] : l.scans)
    if (stamp >= l.first_rx && stamp + kScanNs <= l.last_rx) inside[stamp] = points;
  ASSERT_GE(inside.size(), 20u) << "live scans " << l.scans.size();

  {
    // The recorder first: it matches the replay's writer during the mock's 1 s delay.
    const double span_s = static_cast<double>(l.last_rx - l.first_rx) / 1e9;
    test::RigChild rec = record({"/sensors/lidar/raw29/points"}, replayed, span_s + 8.0);
    test::RigChild up({"up", config("replay.yaml", "{kind: mcap, file: " + live + ", delay: 2}"), "--duration", "60"},
                      (dir_.path / "up_replay.out").string(), (dir_.path / "up_replay.err").string());
    ASSERT_TRUE(up.started());
    ASSERT_EQ(rec.wait(120'000), 0) << rec.err();
    up.signal_and_wait(SIGINT, 20'000);
    EXPECT_EQ(rec.summary()["raw_off"], nullptr) << "a named recording records no other topic";
  }
  const Recorded r = read_recording(replayed, "raw29");
  EXPECT_EQ(r.packets, 0u) << "the raw channel was not asked for";
  std::size_t matched = 0;
  for (const auto& [stamp, points] : inside) {
    const auto it = r.scans.find(stamp);
    if (it == r.scans.end()) {
      ADD_FAILURE() << "live scan " << stamp << " (" << points << " points) not replayed";
      continue;
    }
    EXPECT_EQ(it->second, points) << "scan " << stamp;
    ++matched;
  }
  EXPECT_EQ(matched, inside.size());
  // Nothing else in that window: a scan split in two or made up would show here.
  std::size_t replayed_inside = 0;
  for (const auto& [stamp, points] : r.scans)
    if (stamp >= inside.begin()->first && stamp <= inside.rbegin()->first) ++replayed_inside;
  EXPECT_EQ(replayed_inside, inside.size());
  std::printf("live: %zu scans, %zu inside the raw recording (%llu packets in %llu messages); replay: %zu scans, %zu matched\n",
              l.scans.size(), inside.size(), static_cast<unsigned long long>(l.packets),
              static_cast<unsigned long long>(l.batches), r.scans.size(), matched);

  // An independent reader decodes the raw channel from the schema in the file.
  const auto j = test::mcap_dump(live);
  ASSERT_FALSE(j.contains("error")) << j.dump().substr(0, 2000);
  EXPECT_EQ(j["undecodable"], 0);
  const auto& ch = j["channels"]["/sensors/lidar/raw29/packets"];
  EXPECT_EQ(ch["schema"], "sensor_rig_msgs/msg/LidarPackets");
  EXPECT_EQ(ch["count"], l.batches);
  std::uint64_t packets = 0, data = 0, position = 0;
  std::multiset<std::uint32_t> fnv;
  for (const auto& m : j["messages"]) {
    if (m["topic"] != "/sensors/lidar/raw29/packets") continue;
    EXPECT_EQ(m["frame_id"], "raw29");
    EXPECT_EQ(m["model"], "VLP-32C");
    for (const auto& p : m["packets"]) {
      ++packets;
      EXPECT_EQ(p["src_address"], 0x7F000001u);  // the mock sends from loopback
      if (p["dst_port"] == port_) {
        ++data;
        EXPECT_EQ(p["size"], kVlp32cPacket);
      } else {
        ++position;
        EXPECT_EQ(p["dst_port"], position_port_);
        EXPECT_EQ(p["size"], kPositionPacket);
      }
    }
    fnv.insert(m["data_fnv"].get<std::uint32_t>());
  }
  EXPECT_EQ(packets, l.packets);
  EXPECT_EQ(data, l.data_packets);
  EXPECT_EQ(position, l.position_packets);
  EXPECT_EQ(fnv, l.batch_fnv) << "payloads differ";

  // A cut recording and one with a corrupt chunk: what is intact is sent, the place is named, exit 1.
  const auto size = std::filesystem::file_size(live);
  const std::string cut = (dir_.path / "cut.mcap").string();
  std::filesystem::copy_file(live, cut);
  std::filesystem::resize_file(cut, size / 2);
  const std::string corrupt = (dir_.path / "corrupt.mcap").string();
  std::filesystem::copy_file(live, corrupt);
  {
    std::fstream f(corrupt, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(size / 3));
    const char junk[16] = {'\x5a', '\x5a', '\x5a', '\x5a', '\x5a', '\x5a', '\x5a', '\x5a',
                           '\x5a', '\x5a', '\x5a', '\x5a', '\x5a', '\x5a', '\x5a', '\x5a'};
    f.write(junk, sizeof junk);
  }
  for (const auto& [file, says] : {std::pair<std::string, std::string>{cut, "offset"}, {corrupt, "chunk at offset"}}) {
    SCOPED_TRACE(file);
    const Recorded intact = read_recording(file, "raw29");
    ASSERT_FALSE(intact.problems.empty());
    ASSERT_GT(intact.packets, 0u);
    ASSERT_LT(intact.packets, l.packets);
    test::RigChild replay({"lidar", "replay", "--mcap", file, "--mcap-topic", "/sensors/lidar/raw29/packets", "--to",
                           "127.0.0.1:" + std::to_string(test::free_udp_port()), "--position-port",
                           std::to_string(test::free_udp_port()), "--rate", "20", "--json"},
                          file + ".out", file + ".err");
    EXPECT_EQ(replay.wait(120'000), 1) << replay.err();
    const auto s = replay.summary();
    ASSERT_FALSE(s.is_discarded()) << replay.out() << replay.err();
    EXPECT_EQ(s["sent_data"].get<std::uint64_t>(), intact.data_packets) << replay.err();
    EXPECT_EQ(s["sent_position"].get<std::uint64_t>(), intact.position_packets);
    EXPECT_NE(replay.err().find("recording ended early"), std::string::npos) << replay.err();
    EXPECT_NE(replay.err().find(says), std::string::npos) << replay.err();
  }
}

// A LIDAR run recorded as a split folder (issue 29): `rig up` with the synthetic VLP-32C while `rig
// record` takes its raw channel and its scans, a file every 0.8 s; then `rig up` with mock {kind:
// mcap, file: FOLDER} replays the folder through the same driver (`rig lidar replay --mcap FOLDER`,
// at rate 2 after 1 s) while another recorder takes the scans. The live scans are those the live
// driver published, as our reader reads them from each file. What the live mock sent is its truth
// record's: every data packet, named by its own time, with its send time.
class LidarSplitReplay : public RawReplay {
 protected:
  struct Sent {
    std::uint64_t seq = 0;  // the mock's, in sending order
    Nanos due = 0, tx = 0;  // when its time came, when it was handed to the socket (vehicle ns)
  };
  struct Run {
    std::string folder;
    std::vector<std::string> files;  // in N order
    std::vector<Recorded> parts;     // each file
    Recorded all;                    // the scans of every file
    std::map<std::uint32_t, Sent> sent;  // the live mock's data packets on the wire, by their µs since the hour
  };

  // The live run under a fault plan without faults (RIG_CHAOS_DIR): its mock writes its truth record.
  // Recorded until a fourth file has 0.2 s: three whole files however long `rig up` and the recorder
  // took to start on this host (a fixed --duration 2.5 left 2 s of packets or less under load).
  Run record_split() {
    Run run{(dir_.path / "live").string(), {}, {}, {}, {}};
    const auto chaos = dir_.path / "chaos";
    std::filesystem::create_directories(chaos);
    faults::write_plan((chaos / "plan.jsonl").string(), faults::Plan{});
    ::setenv("RIG_CHAOS_DIR", chaos.c_str(), 1);
    test::RigChild up({"up", config("live.yaml", "{kind: synthetic, rpm: 600}"), "--duration", "60"},
                      (dir_.path / "up_live.out").string(), (dir_.path / "up_live.err").string());
    ::unsetenv("RIG_CHAOS_DIR");
    EXPECT_TRUE(up.started());
    test::RigChild rec = record({"/sensors/lidar/raw29/packets", "/sensors/lidar/raw29/points", "--split-s", "0.8",
                                 "--chunk-kb", "64"}, run.folder, 60.0);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while ((!std::filesystem::exists(run.folder) || split_files(run.folder).size() < 4) && rec.poll() < 0 &&
           std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    EXPECT_EQ(rec.signal_and_wait(SIGINT, 20'000), 0) << rec.err();
    up.signal_and_wait(SIGINT, 20'000);  // the mock ends with it: its record is complete
    run.files = split_files(run.folder);
    read(run);
    for (const auto& p : truth::read((chaos / "truth" / "raw29.jsonl").string()).parts)
      if (p.tx_ns > 0 && truth::delivered_intact(p.fate))
        run.sent[static_cast<std::uint32_t>(p.dev_ns / 1000)] = {p.seq, p.acq_ns, p.tx_ns};
    expect_truth_names_every_packet(run);
    std::printf("%s\n", describe(run).c_str());
    return run;
  }

  // File i of a recording as @mcap/core reads it has the scans (stamp, FNV-1a of the cloud) and the
  // raw packets ours finds: the live truth does not rest on our reader alone. (One file: node
  // decodes ~1000 raw packets a second.)
  static void expect_mcap_core_reads_the_same(const Run& run, std::size_t i) {
    const auto j = test::mcap_dump(run.files[i]);
    ASSERT_FALSE(j.contains("error")) << run.files[i] << ": " << j.dump().substr(0, 2000);
    std::map<Nanos, std::uint32_t> clouds;
    std::uint64_t packets = 0;
    for (const auto& m : j["messages"]) {
      if (m["topic"] == "/sensors/lidar/raw29/points")
        clouds[std::stoll(m["stamp_ns"].get<std::string>())] = m["data_fnv"].get<std::uint32_t>();
      else if (m["topic"] == "/sensors/lidar/raw29/packets")
        packets += m["packets"].size();
    }
    EXPECT_GT(clouds.size(), 0u);
    EXPECT_EQ(clouds, run.parts[i].clouds) << run.files[i];
    EXPECT_EQ(packets, run.parts[i].packets) << run.files[i];
  }

  // Each file as our reader reads it now (after a cut: what is intact).
  static void read(Run& run) {
    run.parts.clear();
    run.all = {};
    for (const auto& f : run.files) {
      run.parts.push_back(read_recording(f, "raw29"));
      const Recorded& p = run.parts.back();
      run.all.scans.insert(p.scans.begin(), p.scans.end());
      run.all.clouds.insert(p.clouds.begin(), p.clouds.end());
      run.all.data_packets += p.data_packets;
      run.all.position_packets += p.position_packets;
    }
  }

  // The folder replayed through the driver: the scans its driver published. `err`: the replaying
  // `rig up`'s stderr, the mock's with it.
  Recorded replay(const std::string& folder, std::string& err) {
    const std::string out = (dir_.path / "replayed.mcap").string();
    test::RigChild rec = record({"/sensors/lidar/raw29/points"}, out, 60.0);
    EXPECT_TRUE(rec.started());
    test::RigChild up({"up", config("replay.yaml", "{kind: mcap, file: " + folder + ", delay: 1, rate: 2}"), "--duration",
                       "60"}, (dir_.path / "up_replay.out").string(), (dir_.path / "up_replay.err").string());
    // The mock's summary line: the recording's last packet is sent (or the mock or `rig up` ended
    // without it: refused).
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (up.err().find("replay: sent ") == std::string::npos && up.err().find("exited with status") == std::string::npos &&
           up.poll() < 0 && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the last scans through DDS to the recorder
    up.signal_and_wait(SIGINT, 20'000);
    EXPECT_EQ(rec.signal_and_wait(SIGINT, 20'000), 0) << rec.err();
    err = up.err();
    return read_recording(out, "raw29");
  }

  // `file` rewritten without `topic`'s channel and messages, or (`which` given) without those of
  // its messages `which` picks.
  static void drop_channel(const std::string& file, const std::string& topic,
                           const std::function<bool(const record::McapMessage&)>& which = {}) {
    const std::string rewritten = file + ".new";
    {
      record::McapReader r(file);
      record::McapWriter w(rewritten, {});
      for (const auto& [id, schema] : r.schemas()) w.add_schema_as_is(schema);
      for (const auto& [id, channel] : r.channels())
        if (channel.topic != topic || which) w.add_channel_as_is(channel);
      r.for_each_message([&](const record::McapMessage& m) {
        if (r.channels().at(m.channel_id).topic == topic && (!which || which(m))) return true;
        const std::span<const std::byte> pieces[1] = {m.data};
        w.write(m.channel_id, m.sequence, m.log_time, m.publish_time, pieces);
        return true;
      });
      w.close();
    }
    std::filesystem::rename(rewritten, file);
  }

  // The mock's datagrams sent, data and position, from its summary line.
  static std::pair<std::uint64_t, std::uint64_t> sent(const std::string& err) {
    unsigned long long data = 0, position = 0;
    const auto at = err.find("replay: sent ");
    if (at == std::string::npos || std::sscanf(err.c_str() + at, "replay: sent %*[0-9] datagrams (data %llu, position %llu)",
                                               &data, &position) != 2)
      ADD_FAILURE() << "no summary line: " << err;
    return {data, position};
  }

  // Every recorded data packet is one the mock sent (its truth record is whole), and none is in the
  // recording twice.
  static void expect_truth_names_every_packet(const Run& run) {
    std::set<std::uint32_t> seen;
    std::size_t unknown = 0, twice = 0;
    for (const auto& p : run.parts)
      for (const auto& [us, rx] : p.data) {
        unknown += run.sent.count(us) == 0;
        twice += !seen.insert(us).second;
      }
    EXPECT_GT(run.sent.size(), 1000u) << "the mock's truth record";
    EXPECT_EQ(unknown, 0u) << "recorded packets the mock's truth record does not name";
    EXPECT_EQ(twice, 0u) << "packets recorded twice";
  }

  // Runs of data packets the mock sent and no file holds, between the first and the last one the
  // files hold (a cut file's lost tail): how many, and the receipts of the recorded packets either
  // side. Ground truth, not time: the mock may send nothing for a while (late on a loaded host),
  // which loses nothing; one packet missing is a loss.
  struct Loss {
    std::uint64_t packets = 0;
    Nanos from = 0, to = 0;
  };
  static std::vector<Loss> losses(const Run& run) {
    std::map<std::uint64_t, Nanos> recorded;  // seq -> receipt
    for (const auto& p : run.parts)
      for (const auto& [us, rx] : p.data)
        if (const auto it = run.sent.find(us); it != run.sent.end()) recorded.emplace(it->second.seq, rx);
    std::vector<std::uint64_t> sent;
    for (const auto& [us, s] : run.sent) sent.push_back(s.seq);
    std::sort(sent.begin(), sent.end());
    std::vector<Loss> l;
    if (recorded.empty()) return l;
    Nanos last = 0;
    bool in_loss = false;
    for (const std::uint64_t seq : sent) {
      if (seq < recorded.begin()->first || seq > recorded.rbegin()->first) continue;
      if (const auto it = recorded.find(seq); it != recorded.end()) {
        if (in_loss) l.back().to = it->second;
        in_loss = false;
        last = it->second;
      } else {
        if (!in_loss) l.push_back({0, last, 0});
        in_loss = true;
        ++l.back().packets;
      }
    }
    return l;
  }

  // The times the recording lost packets the mock sent (losses()), from the last recorded packet
  // before to the first after.
  static std::vector<std::pair<Nanos, Nanos>> gaps(const Run& run) {
    std::vector<std::pair<Nanos, Nanos>> g;
    for (const auto& l : losses(run)) g.emplace_back(l.from, l.to);
    return g;
  }

  // What the mock sent, what the files hold, where the files meet and what was lost: a test's line,
  // and a failure's explanation. A seam's time without packets is the mock's (it sent none then)
  // when nothing was lost.
  static std::string describe(const Run& run) {
    Nanos late = 0;
    for (const auto& [us, s] : run.sent) late = std::max(late, s.tx - s.due);
    std::ostringstream o;
    o << "mock: " << run.sent.size() << " data packets sent (at most " << static_cast<double>(late) / 1e6
      << " ms late); files: " << run.files.size() << ", data packets";
    const Recorded* before = nullptr;
    for (const auto& p : run.parts) {
      o << " " << p.data.size();
      if (before != nullptr && !p.data.empty() && !before->data.empty())
        o << " (seam " << static_cast<double>(p.data.front().second - before->data.back().second) / 1e6 << " ms)";
      if (!p.data.empty()) before = &p;
    }
    // The mock's pauses while recorded: more than 5 ms without a packet sent (what a seam without
    // packets that long was taken for: a loss).
    Nanos first = INT64_MAX, last = 0;
    for (const auto& p : run.parts) {
      if (p.data.empty()) continue;
      first = std::min(first, p.data.front().second);
      last = std::max(last, p.data.back().second);
    }
    std::vector<Nanos> tx;
    for (const auto& [us, s] : run.sent)
      if (s.tx >= first && s.tx <= last) tx.push_back(s.tx);
    std::sort(tx.begin(), tx.end());
    std::size_t pauses = 0;
    Nanos paused = 0;
    for (std::size_t i = 1; i < tx.size(); ++i)
      if (tx[i] - tx[i - 1] > 5'000'000) {
        ++pauses;
        paused += tx[i] - tx[i - 1];
      }
    o << "; mock pauses over 5 ms: " << pauses << " (" << static_cast<double>(paused) / 1e6 << " ms)";
    const auto l = losses(run);
    o << "; lost: " << l.size();
    for (const auto& x : l)
      o << " [" << x.packets << " packets between " << x.from << " and " << x.to << "]";
    return o.str();
  }

  // Each live scan wholly inside the recorded packets and clear of its gaps (5 ms around: the packets' way
  // from firing to receipt) must come out of the replay with the same stamp and the same cloud,
  // byte for byte; the replay has no other scan clear of the gaps in that window (none split, made
  // up or doubled). Returns the live scans checked.
  static std::vector<Nanos> expect_scans_replayed(const Run& live, const Recorded& replayed) {
    const auto g = gaps(live);
    const auto first = std::find_if(live.parts.begin(), live.parts.end(), [](const Recorded& p) { return p.packets > 0; });
    const Nanos first_rx = first->first_rx, last_rx = live.parts.back().last_rx;
    const auto clear = [&](Nanos stamp) {
      return std::all_of(g.begin(), g.end(), [&](const auto& gap) {
        return stamp + kScanNs + 5'000'000 < gap.first || stamp - 5'000'000 > gap.second;
      });
    };
    std::vector<Nanos> checked;
    for (const auto& [stamp, points] : live.all.scans)
      if (stamp >= first_rx && stamp + kScanNs <= last_rx && clear(stamp)) checked.push_back(stamp);
    EXPECT_GE(checked.size(), 15u) << "live scans " << live.all.scans.size();
    if (checked.empty()) return checked;
    std::size_t equal = 0;
    for (const Nanos stamp : checked) {
      const auto it = replayed.clouds.find(stamp);
      if (it == replayed.clouds.end()) {
        ADD_FAILURE() << "live scan " << stamp << " (" << live.all.scans.at(stamp) << " points) not replayed";
      } else if (it->second != live.all.clouds.at(stamp) || replayed.scans.at(stamp) != live.all.scans.at(stamp)) {
        ADD_FAILURE() << "scan " << stamp << ": replayed " << replayed.scans.at(stamp) << " points, live "
                      << live.all.scans.at(stamp) << "; or their bytes differ";
      } else {
        ++equal;
      }
    }
    for (const auto& [stamp, points] : replayed.scans) {
      const bool in_window = stamp >= checked.front() && stamp <= checked.back() && clear(stamp);
      EXPECT_TRUE(!in_window || std::binary_search(checked.begin(), checked.end(), stamp))
          << "replayed scan " << stamp << " was not live";
    }
    std::set<std::uint32_t> distinct;
    for (const Nanos stamp : checked) distinct.insert(live.all.clouds.at(stamp));
    std::printf("live: %zu scans in %zu files, %zu checked (%zu distinct clouds), %zu gaps; replay: %zu scans, %zu equal\n",
                live.all.scans.size(), live.files.size(), checked.size(), distinct.size(), g.size(),
                replayed.scans.size(), equal);
    return checked;
  }

  // The checked scans whose packets lie in two files.
  static std::size_t across_seams(const Run& live, const std::vector<Nanos>& checked) {
    std::size_t n = 0;
    for (const Nanos stamp : checked)
      for (std::size_t i = 0; i + 1 < live.parts.size(); ++i)
        if (live.parts[i].last_rx > stamp && live.parts[i].last_rx < stamp + kScanNs) {
          ++n;
          break;
        }
    return n;
  }
};

// `mock: {kind: mcap, file: FOLDER}`: the split recording replays as one stream, every scan equal
// to the live one across the seams, and every recorded packet sent.
TEST_F(LidarSplitReplay, SplitRecordingFolderReplaysEveryScanAsLive) {
  const Run live = record_split();
  ASSERT_GE(live.files.size(), 4u) << "a file every 0.8 s";
  ASSERT_TRUE(gaps(live).empty()) << "the live recording lost packets the mock sent: " << describe(live);
  expect_mcap_core_reads_the_same(live, 1);  // a file between two seams
  std::string err;
  const Recorded replayed = replay(live.folder, err);
  const auto checked = expect_scans_replayed(live, replayed);
  // Each seam with a scan's time of packets either side lies inside a checked scan (the last file
  // may be shorter than a scan).
  std::size_t interior = 0;
  for (std::size_t i = 0; i + 1 < live.parts.size(); ++i)
    interior += live.parts[i].last_rx - live.parts.front().first_rx > kScanNs + 10'000'000 &&
                live.parts.back().last_rx - live.parts[i].last_rx > kScanNs + 10'000'000;
  EXPECT_GE(interior, 2u);
  EXPECT_GE(across_seams(live, checked), interior);
  const auto [data, position] = sent(err);
  EXPECT_EQ(data, live.all.data_packets);
  EXPECT_EQ(position, live.all.position_packets);
  EXPECT_EQ(err.find("ended early"), std::string::npos) << err;
  std::printf("%zu scans across seams; sent %llu data + %llu position packets\n", across_seams(live, checked),
              static_cast<unsigned long long>(data), static_cast<unsigned long long>(position));
}

// The same with its second file cut to two thirds: the mock names the cut file and the offset, and
// every scan of what is intact (the cut file's first part, the files after it) replays as live.
TEST_F(LidarSplitReplay, SplitRecordingWithACutFileReplaysTheIntactScans) {
  Run live = record_split();
  ASSERT_GE(live.files.size(), 4u) << "a file every 0.8 s";
  ASSERT_TRUE(gaps(live).empty()) << "the live recording lost packets the mock sent: " << describe(live);
  const std::string cut = live.files[1];
  const std::size_t whole = live.parts[1].data.size();
  std::filesystem::resize_file(cut, std::filesystem::file_size(cut) * 2 / 3);
  read(live);
  ASSERT_FALSE(live.parts[1].problems.empty());
  // One loss, the cut file's tail: its packets, up to the next file's first.
  const auto lost = losses(live);
  ASSERT_EQ(lost.size(), 1u) << describe(live);
  EXPECT_EQ(lost[0].packets, whole - live.parts[1].data.size()) << describe(live);
  ASSERT_FALSE(live.parts[2].data.empty());
  EXPECT_EQ(lost[0].to, live.parts[2].data.front().second) << describe(live);
  {
    // The same count finds one message of data packets missing (a copy of file 2 without its 100th
    // or the next that has data): a loss inside a file, and shorter than a seam's 5 ms.
    Run one = live;
    const std::string copy = (dir_.path / "one_less.mcap").string();
    std::filesystem::copy_file(live.files[2], copy);
    int n = 0;
    bool dropped = false;
    drop_channel(copy, "/sensors/lidar/raw29/packets", [&](const record::McapMessage& m) {
      if (dropped || ++n < 100) return false;
      dds::LidarPacketsView v;
      const auto body = dds::cdr_body(m.data);
      dropped = body && dds::parse_cdr(*body, v) == dds::CdrStatus::kOk && !v.packets.empty() &&
                v.packets.front().dst_port == v.data_port;
      return dropped;
    });
    one.parts[2] = read_recording(copy, "raw29");
    const auto l = losses(one);
    ASSERT_EQ(l.size(), 2u) << describe(one);
    EXPECT_EQ(l[1].packets, live.parts[2].data.size() - one.parts[2].data.size());
    EXPECT_GT(l[1].packets, 0u);
  }
  std::string err;
  const Recorded replayed = replay(live.folder, err);
  const auto checked = expect_scans_replayed(live, replayed);
  const auto within = [&](std::size_t file) {
    return std::count_if(checked.begin(), checked.end(), [&](Nanos stamp) {
      return stamp >= live.parts[file].first_rx && stamp + kScanNs <= live.parts[file].last_rx;
    });
  };
  EXPECT_GT(within(1), 0) << "no intact scan of the cut file checked";
  EXPECT_GT(within(2), 0) << "no scan of the file after the cut checked";
  const auto [data, position] = sent(err);
  EXPECT_EQ(data, live.all.data_packets) << "the intact packets";
  EXPECT_EQ(position, live.all.position_packets);
  const auto at = err.find("recording ended early: ");
  ASSERT_NE(at, std::string::npos) << err;
  const auto named = err.find(cut + ": ", at);
  EXPECT_NE(named, std::string::npos) << err;
  EXPECT_NE(err.find("offset", named), std::string::npos) << err;
  std::printf("%s\n", err.substr(at, err.find('\n', at) - at).c_str());
}

// The same whose first file holds no raw channel (the recorder's LIDAR raw channel matched after the
// first split: its scans are there, not its packets; a file holds a channel only with a message of
// it): the replay begins at the first file that has it, every scan of the files after it replays as
// live, and nothing is called damaged.
TEST_F(LidarSplitReplay, SplitRecordingWhoseFirstFileLacksTheChannelReplaysFromTheNext) {
  Run live = record_split();
  ASSERT_GE(live.files.size(), 4u) << "a file every 0.8 s";
  drop_channel(live.files[0], "/sensors/lidar/raw29/packets");
  read(live);
  ASSERT_EQ(live.parts[0].packets, 0u);
  ASSERT_GT(live.parts[0].scans.size(), 0u);
  std::string err;
  const Recorded replayed = replay(live.folder, err);
  expect_scans_replayed(live, replayed);
  const auto [data, position] = sent(err);
  EXPECT_EQ(data, live.all.data_packets);
  EXPECT_EQ(position, live.all.position_packets);
  EXPECT_EQ(err.find("ended early"), std::string::npos) << err;
  EXPECT_EQ(err.find("cannot replay"), std::string::npos) << err;
}
}  // namespace
}  // namespace sensor_rig::rig
