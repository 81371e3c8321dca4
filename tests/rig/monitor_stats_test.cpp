// The monitor's per-topic join of data and source stamps, and its sample record (CSV), without DDS.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <vector>

#include "monitor_stats.hpp"
#include "sample_record.hpp"
#include "rig_process.hpp"

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::rig {
namespace {

constexpr Nanos kT0 = 1'700'000'000'000'000'000;

// The stamps a driver publishes for sample `seq` acquired at kT0 + seq * 100 ms.
msg::SourceStamps stamps(std::uint64_t seq, std::uint32_t missing = 0) {
  msg::SourceStamps s{};
  const Nanos acq = kT0 + static_cast<Nanos>(seq) * 100 * kMs;
  s.header.stamp = msg::to_time(acq);
  s.seq = seq;
  s.acquisition_ns = acq;
  s.first_rx_ns = acq + 1 * kMs;
  s.last_rx_ns = acq + 101 * kMs;
  s.ready_ns = acq + 102 * kMs;
  s.publish_ns = acq + 103 * kMs;
  s.written_ns = acq + 104 * kMs;
  s.missing_packets = missing;
  s.size_bytes = 1000;
  return s;
}
Nanos stamp_of(std::uint64_t seq) { return kT0 + static_cast<Nanos>(seq) * 100 * kMs; }
Arrival arrival(std::uint64_t seq) { return {stamp_of(seq) + 110 * kMs, stamp_of(seq) + 103 * kMs}; }

struct Recorded {
  TopicStats st;
  std::vector<SampleRecord> rows;
  Recorded() {
    st.name = "/sensors/lidar/front/points";
    st.counting.since = 0;
    st.on_record = [this](const SampleRecord& r) { rows.push_back(r); };
  }
};

TEST(MonitorStats, JoinsDataAndStampsInEitherOrderWithEveryStage) {
  Recorded t;
  t.st.on_stamps(stamps(0), stamp_of(0));
  t.st.on_data(stamp_of(0), 1000, arrival(0));
  t.st.on_data(stamp_of(1), 1000, arrival(1));  // data first
  t.st.on_stamps(stamps(1, 3), stamp_of(1));
  ASSERT_EQ(t.rows.size(), 2u);
  EXPECT_EQ(t.rows[0].seq, 0u);
  EXPECT_EQ(t.rows[1].seq, 1u);
  EXPECT_EQ(t.rows[1].missing_packets, 3u);
  EXPECT_EQ(t.rows[1].received_ns, arrival(1).receive_ns);
  EXPECT_EQ(t.rows[0].topic, "/sensors/lidar/front/points");
  EXPECT_EQ(t.st.missing_packets, 3u);
  const auto p = t.st.stages[kSensor].take();
  EXPECT_EQ(p.n, 2u);
  EXPECT_DOUBLE_EQ(p.max, 1.0);
  EXPECT_DOUBLE_EQ(t.st.stages[kTotal].take().p50, 110.0);
  EXPECT_DOUBLE_EQ(t.st.stages[kDds].take().p50, 7.0);
}

TEST(MonitorStats, LostSampleHoldsLaterRowsSoSeqStaysInOrder) {
  Recorded t;
  for (std::uint64_t seq = 0; seq < 4; ++seq) t.st.on_stamps(stamps(seq), stamp_of(seq));
  t.st.on_data(stamp_of(0), 1000, arrival(0));
  t.st.on_data(stamp_of(2), 1000, arrival(2));  // 1 not (yet) here: 2 waits
  t.st.on_data(stamp_of(3), 1000, arrival(3));
  ASSERT_EQ(t.rows.size(), 1u);
  t.st.expire(stamp_of(1) + 500 * kMs, 2000 * kMs);  // not yet lost
  EXPECT_EQ(t.rows.size(), 1u);
  EXPECT_EQ(t.st.lost, 0u);
  t.st.expire(stamp_of(1) + 2001 * kMs, 2000 * kMs);
  EXPECT_EQ(t.st.lost, 1u);
  ASSERT_EQ(t.rows.size(), 4u);
  for (std::uint64_t seq = 0; seq < 4; ++seq) EXPECT_EQ(t.rows[seq].seq, seq);
  EXPECT_TRUE(t.rows[1].lost());
  EXPECT_FALSE(t.rows[2].lost());
  EXPECT_EQ(t.rows[1].publish_ns, stamp_of(1) + 103 * kMs);  // the stamps it had are kept
}

// The loss timeout is the monitor's guess: a sample that still comes after it was late, not lost
// (the old accounting kept it lost and dropped the data as unmatched).
TEST(MonitorStats, DataAfterTheLossTimeoutIsLateNotLost) {
  Recorded t;
  t.st.on_stamps(stamps(0), stamp_of(0));
  t.st.expire(stamp_of(0) + 2001 * kMs, 2000 * kMs);
  EXPECT_EQ(t.st.lost, 1u);
  t.st.on_data(stamp_of(0), 1000, {stamp_of(0) + 2500 * kMs, stamp_of(0) + 103 * kMs});
  EXPECT_EQ(t.st.lost, 0u);
  EXPECT_EQ(t.st.late, 1u);
  EXPECT_EQ(t.st.received, 1u);
  t.st.on_data(stamp_of(0), 1000, arrival(0));  // once only
  EXPECT_EQ(t.st.late, 1u);
}

// A reliable writer delivers in order: samples written before the first one the reader got were
// written before it matched the reader (start-up under load), not lost — waiting or declared so.
TEST(MonitorStats, SamplesWrittenBeforeTheFirstReceivedAreBeforeMatchNotLost) {
  Recorded t;
  t.st.on_stamps(stamps(0), stamp_of(0));
  t.st.on_stamps(stamps(1), stamp_of(1));
  t.st.expire(stamp_of(0) + 2001 * kMs, 2000 * kMs);  // 0 declared lost, 1 still waiting
  EXPECT_EQ(t.st.lost, 1u);
  t.st.on_stamps(stamps(2), stamp_of(2));
  t.st.on_data(stamp_of(2), 1000, arrival(2));  // the first sample that reached the reader
  EXPECT_EQ(t.st.lost, 0u);
  EXPECT_EQ(t.st.before_match, 2u);
  t.st.on_stamps(stamps(3), stamp_of(3));  // after it: lost as before
  t.st.expire(stamp_of(3) + 5000 * kMs, 2000 * kMs);
  EXPECT_EQ(t.st.lost, 1u);
  EXPECT_EQ(t.st.before_match, 2u);
}

// Data whose stamps never came (the stamps reader fell behind) is counted, not silently dropped.
TEST(MonitorStats, DataWithoutStampsIsCountedUnstamped) {
  Recorded t;
  t.st.on_stamps(stamps(0), stamp_of(0));
  t.st.on_data(stamp_of(0), 1000, arrival(0));
  t.st.on_data(stamp_of(1), 1000, arrival(1));  // its stamps are never seen
  t.st.expire(arrival(1).receive_ns + 1000 * kMs, 2000 * kMs);
  EXPECT_EQ(t.st.unstamped, 0u);  // not yet
  t.st.expire(arrival(1).receive_ns + 2001 * kMs, 2000 * kMs);
  EXPECT_EQ(t.st.unstamped, 1u);
  EXPECT_EQ(t.st.lost, 0u);
}

// A camera node's drop counters from /diagnostics, counted from the first status the monitor saw.
TEST(CameraDrops, CountsEachStageFromTheFirstStatus) {
  CameraDrops d;
  d.on_status({{"underruns", "3"}, {"incomplete_timeout", "1"}, {"write_errors", "2"}, {"frames", "100"}});
  d.on_status({{"underruns", "5"}, {"incomplete_timeout", "1"}, {"incomplete_missing_packets", "4"},
               {"incomplete_other", "1"}, {"worker_dropped", "7"}, {"write_errors", "3"}});
  EXPECT_EQ(d.since_start(0), 2u);  // underruns
  EXPECT_EQ(d.since_start(1), 0u);  // timeouts
  EXPECT_EQ(d.since_start(2), 4u);  // missing packets
  EXPECT_EQ(d.since_start(3), 1u);
  EXPECT_EQ(d.since_start(4), 7u);
  EXPECT_EQ(d.write_errors(), 1u);
  d.on_status({{"underruns", "1"}, {"write_errors", "0"}});  // the node restarted
  EXPECT_EQ(d.since_start(0), 1u);
  EXPECT_EQ(d.write_errors(), 0u);
}

// Lost samples a failed write or the reader's DDS status explains are not lost_in_dds.
TEST(CameraDrops, LostSamplesAreAttributedToWriterAndReaderFirst) {
  TopicStats st;
  st.reader_lost = 1;
  st.lost = 4;
  st.camera.on_status({{"write_errors", "10"}});
  st.camera.on_status({{"write_errors", "12"}, {"underruns", "0"}});
  std::map<std::string_view, std::uint64_t> by;
  for (const auto& [k, v] : drops_by_stage(st)) by[k] = v;
  EXPECT_EQ(by["dds_write"], 2u);
  EXPECT_EQ(by["reader_lost"], 1u);
  EXPECT_EQ(by["lost_in_dds"], 1u);
  EXPECT_EQ(by.count("aravis_underrun"), 1u);
}

TEST(MonitorStats, StampsBeforeSubscribingAreNotCountedNorRecorded) {
  Recorded t;
  t.st.counting.since = stamp_of(2);
  t.st.on_stamps(stamps(0), stamp_of(0));
  t.st.expire(stamp_of(0) + 10'000 * kMs, 2000 * kMs);
  EXPECT_EQ(t.st.lost, 0u);
  EXPECT_TRUE(t.rows.empty());
  EXPECT_TRUE(t.st.has_stamps);
}

// Once a stamp published after the reader matched has come, every later one counts: a host clock
// stepped back further than the monitor had run put the publish times of every stamp during the step
// before counting.since, and the monitor ignored them (a -37 s step: 50 scans of each LIDAR
// "neither published nor counted lost").
TEST(MonitorStats, AClockStepBackAfterCountingBeganStillCountsAndRecords) {
  Recorded t;
  t.st.counting.since = stamp_of(2);
  t.st.on_stamps(stamps(2), stamp_of(2));
  t.st.on_data(stamp_of(2), 1000, arrival(2));
  ASSERT_EQ(t.rows.size(), 1u);
  // The host clock steps back 37 s: the next stamps are published "before" counting began.
  constexpr Nanos kStep = 37'000 * kMs;
  for (std::uint64_t seq = 3; seq < 6; ++seq) {
    auto s = stamps(seq);
    s.publish_ns -= kStep;
    s.written_ns -= kStep;
    t.st.on_stamps(s, stamp_of(seq) - kStep);
    if (seq != 4) t.st.on_data(stamp_of(seq), 1000, Arrival{arrival(seq).receive_ns - kStep, arrival(seq).publish_ns - kStep});
  }
  t.st.expire(stamp_of(4) - kStep + 10'000 * kMs, 2000 * kMs);
  EXPECT_EQ(t.st.lost, 1u) << "seq 4 never came: lost, not ignored";
  t.st.release_all();
  ASSERT_EQ(t.rows.size(), 4u) << "seq 3 and 5 recorded, seq 4 recorded lost";
  EXPECT_EQ(t.rows[1].seq, 3u);
  EXPECT_EQ(t.rows[3].seq, 5u);
}

TEST(MonitorStats, ReleaseAllAtTheEndKeepsUndecidedOut) {
  Recorded t;
  t.st.on_data(stamp_of(0), 1000, arrival(0));  // the reader is matched
  t.st.on_stamps(stamps(0), stamp_of(0));
  t.st.on_stamps(stamps(1), stamp_of(1));  // never arrives, never expires
  t.st.on_stamps(stamps(2), stamp_of(2));
  t.st.on_data(stamp_of(2), 1000, arrival(2));
  EXPECT_EQ(t.rows.size(), 1u);
  t.st.release_all();
  ASSERT_EQ(t.rows.size(), 2u);
  EXPECT_EQ(t.rows[1].seq, 2u);
}

// Units the node counted lost itself (its /diagnostics scans_lost, cumulative): counted from the
// monitor's first status, across a restart of the node (its count starts again from 0). Issue 26.
TEST(MonitorStats, CountedLostFollowsTheNodeAcrossARestart) {
  TopicStats st;
  EXPECT_EQ(st.counted_lost(), 0U);
  st.on_counted_lost(7);  // before this monitor: not its to count
  EXPECT_EQ(st.counted_lost(), 0U);
  st.on_counted_lost(9);
  EXPECT_EQ(st.counted_lost(), 2U);
  st.on_counted_lost(1);  // the node restarted
  EXPECT_EQ(st.counted_lost(), 3U);
  st.on_counted_lost(4);
  EXPECT_EQ(st.counted_lost(), 6U);
  // A LIDAR's unheard turns are counted alike, on their own.
  st.on_unheard(3);
  st.on_unheard(5);
  EXPECT_EQ(st.unheard(), 2U);
  EXPECT_EQ(st.counted_lost(), 6U);
}

TEST(SampleRecord, StageLatenciesNeedBothStamps) {
  SampleRecord r;
  r.acquisition_ns = kT0;
  r.publish_ns = kT0 + 5 * kMs;
  r.received_ns = kT0 + 7 * kMs;
  const auto s = stage_latencies_ms(r);
  EXPECT_FALSE(s[kSensor]);
  EXPECT_FALSE(s[kWrite]);
  ASSERT_TRUE(s[kDds]);
  EXPECT_DOUBLE_EQ(*s[kDds], 2.0);
  ASSERT_TRUE(s[kTotal]);
  EXPECT_DOUBLE_EQ(*s[kTotal], 7.0);
}

TEST(SampleRecord, CsvLineRoundTripsWithEmptyUnknownTimes) {
  SampleRecord r;
  r.topic = "/sensors/camera/front_narrow/image_raw";
  r.seq = 42;
  r.acquisition_ns = kT0;
  r.publish_ns = kT0 + 3;
  r.written_ns = kT0 + 4;
  r.missing_packets = 7;
  r.dropped = 1;
  r.size_bytes = 2'304'000;
  r.packets = 1600;
  const std::string line = to_csv_line(r);
  EXPECT_EQ(line, "/sensors/camera/front_narrow/image_raw,42,1700000000000000000,,,1700000000000000003,"
                  "1700000000000000004,,7,1,2304000,,1600\n");
  const auto back = parse_csv_line(line.substr(0, line.size() - 1));
  ASSERT_TRUE(back);
  EXPECT_EQ(back->topic, r.topic);
  EXPECT_EQ(back->seq, 42u);
  EXPECT_EQ(back->first_rx_ns, 0);
  EXPECT_EQ(back->written_ns, kT0 + 4);
  EXPECT_TRUE(back->lost());
  EXPECT_EQ(back->size_bytes, 2'304'000u);
  EXPECT_EQ(back->packets, 1600u);
  EXPECT_EQ(std::count(record_csv_header().begin(), record_csv_header().end(), ','), 12);
  EXPECT_EQ(back->ecu_status_ns, 0);
  EXPECT_FALSE(stage_latencies_ms(*back)[kEcu]) << "no ECU status, no ecu stage";
  // A drive-by-wire command: CAN frames written, then the ECU status 4.5 ms later (last column).
  r.ecu_status_ns = r.written_ns + 4'500'000;
  const std::string dbw = to_csv_line(r);
  EXPECT_EQ(dbw.substr(dbw.rfind(",2304000,")), ",2304000,1700000000004500004,1600\n");
  const auto dbw_back = parse_csv_line(dbw.substr(0, dbw.size() - 1));
  ASSERT_TRUE(dbw_back);
  EXPECT_EQ(dbw_back->ecu_status_ns, r.ecu_status_ns);
  const auto s = stage_latencies_ms(*dbw_back);
  ASSERT_TRUE(s[kEcu]);
  EXPECT_DOUBLE_EQ(*s[kEcu], 4.5);
  EXPECT_STREQ(kStageNames[kEcu], "ecu");
}

TEST(SampleRecord, BadLinesAreRefused) {
  for (const char* bad : {"", "/a,1,2", "/a,1,,,,,,,,,,,", "/a,1,,,,,,,0,0,0,,9,", "/a,x,,,,,,,0,0,0,,0", "/a,1,,,,,,,0,0,-1,,0",
                          ",1,,,,,,,0,0,0,,0", "/a,1,12abc,,,,,,0,0,0,,0", "/a,99999999999999999999,,,,,,,0,0,0,,0",
                          "/a,1,,,,,,,0,0,0,x,0", "/a,1,,,,,,,0,0,0,", "/a,1,,,,,,,0,0,0,,-1", "/a,1,,,,,,,0,0,0,,0,0"})
    EXPECT_FALSE(parse_csv_line(bad)) << bad;
  EXPECT_TRUE(parse_csv_line("/a,1,,,,,,,0,0,0,,0"));
  EXPECT_TRUE(parse_csv_line("/a,1,,,,,,,0,0,0,9,120"));
}

// A recording made before the `ecu_status_ns` column (11 columns) still reads: no ECU time.
TEST(SampleRecord, RecordingWithoutTheEcuColumnReads) {
  test::TempDir dir;
  const std::string with_ecu(record_csv_header().substr(0, record_csv_header().rfind(',')));
  const auto twelve = read_records(dir.write("twelve.csv", with_ecu + "\n/a,1,,,,5,6,7,0,0,10,11\n"));
  ASSERT_EQ(twelve.size(), 1u);
  EXPECT_EQ(twelve[0].ecu_status_ns, 11);
  EXPECT_EQ(twelve[0].packets, 0u) << "before the packets column: not known";
  const std::string header(with_ecu.substr(0, with_ecu.rfind(',')));
  const std::string old = dir.write("old.csv", header + "\n/a,1,,,,5,6,7,0,0,10\n/a,2,,,,8,9,,0,0,10\n");
  const auto rows = read_records(old);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].received_ns, 7);
  EXPECT_EQ(rows[0].ecu_status_ns, 0);
  EXPECT_TRUE(rows[1].lost());
  // Each file's own width: a 12-column line under the old header is bad input, and the reverse.
  EXPECT_THROW(read_records(dir.write("mixed.csv", header + "\n/a,1,,,,5,6,7,0,0,10,11\n")), std::runtime_error);
  EXPECT_THROW(read_records(dir.write("short.csv", std::string(record_csv_header()) + "\n/a,1,,,,5,6,7,0,0,10\n")),
               std::runtime_error);
  EXPECT_THROW(read_records(dir.write("none.csv", "topic,seq\n")), std::runtime_error);
}

TEST(SampleRecord, FileHoldsWholeLinesAndReadsBack) {
  test::TempDir dir;
  const std::string path = (dir.path / "r.csv").string();
  {
    RecordFile f(path);
    SampleRecord r;
    r.topic = "/t";
    for (std::uint64_t seq = 0; seq < 3; ++seq) {
      r.seq = seq;
      f.add(r);
    }
    // Nothing but the header until flush(): a kill in between leaves no half line.
    std::ifstream in(path);
    std::stringstream s;
    s << in.rdbuf();
    EXPECT_EQ(s.str(), std::string(record_csv_header()) + "\n");
    f.flush();
    EXPECT_EQ(f.rows(), 3u);
  }
  const auto rows = read_records(path);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[2].seq, 2u);
  const std::string other = dir.write("other.csv", "t,seq\n/t,1\n");
  EXPECT_THROW(read_records(other), std::runtime_error);
  const std::string broken = dir.write("broken.csv", std::string(record_csv_header()) + "\n/t,1,,,,,,,0,0,0,,0\n/t,2,oops\n");
  try {
    read_records(broken);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("broken.csv:3"), std::string::npos) << e.what();
  }
  EXPECT_THROW(RecordFile((dir.path / "no/such/dir/r.csv").string()), std::runtime_error);
}

// A LIDAR-triggered camera's /diagnostics values as the monitor reads them.
TEST(TriggerStats, ReadsTheCameraTriggerKeys) {
  TriggerStats t;
  EXPECT_TRUE(t.on_value("trigger_lidar", "front"));
  EXPECT_TRUE(t.on_value("trigger_sweep", "locked"));
  EXPECT_TRUE(t.on_value("triggers", "600"));
  EXPECT_TRUE(t.on_value("phase_measured", "597"));
  EXPECT_TRUE(t.on_value("phase_unmeasured", "3"));
  EXPECT_TRUE(t.on_value("phase_error_p50_ms", "0.034"));
  EXPECT_TRUE(t.on_value("phase_error_p99_ms", "0.506"));
  EXPECT_TRUE(t.on_value("phase_error_max_ms", "6.814"));
  EXPECT_FALSE(t.on_value("frames", "627"));
  EXPECT_FALSE(t.on_value("triggers", "n/a"));  // not a number: refused, the count kept
  EXPECT_EQ(t.lidar, "front");
  EXPECT_EQ(t.sweep, "locked");
  EXPECT_EQ(t.triggers, 600u);
  EXPECT_EQ(t.measured, 597u);
  EXPECT_EQ(t.unmeasured, 3u);
  EXPECT_DOUBLE_EQ(t.p50_ms, 0.034);
  EXPECT_DOUBLE_EQ(t.p99_ms, 0.506);
  EXPECT_DOUBLE_EQ(t.max_ms, 6.814);
}

// A trigger status as the camera node publishes it: every key is a trigger key the monitor reads.
TriggerStats read_trigger_status(const std::map<std::string, std::string>& values) {
  TriggerStats t;
  for (const auto& [k, v] : values) EXPECT_TRUE(t.on_value(k, v)) << k;
  return t;
}

// A camera reporting its exposure start: where the phase comes from and its host / camera split,
// parsed from the status and shown in the table and the --json/--summary object.
TEST(TriggerStats, ReadsAndShowsWhereThePhaseComesFromAndItsSplit) {
  TriggerStats t = read_trigger_status({{"trigger_lidar", "front"},
                                        {"trigger_sweep", "locked"},
                                        {"triggers", "600"},
                                        {"phase_unmeasured", "3"},
                                        {"phase_from", "device_exposure"},
                                        {"phase_error_p50_ms", "0.412"},
                                        {"phase_error_p99_ms", "0.900"},
                                        {"phase_error_max_ms", "1.250"},
                                        {"trigger_call_error_p50_ms", "0.021"},
                                        {"trigger_call_error_p99_ms", "0.187"},
                                        {"trigger_call_error_max_ms", "0.500"},
                                        {"trigger_to_exposure_p50_ms", "0.390"},
                                        {"trigger_to_exposure_p99_ms", "0.811"},
                                        {"trigger_to_exposure_max_ms", "1.100"},
                                        {"exposure_unmatched", "7"}});
  EXPECT_FALSE(t.on_value("trigger_call_error_p90_ms", "1"));     // not a published figure
  EXPECT_FALSE(t.on_value("trigger_to_exposure_p50_ms", "n/a"));  // not a number: the figure kept
  EXPECT_EQ(t.phase_from, "device_exposure");
  EXPECT_EQ(t.exposure_unmatched, 7u);
  EXPECT_DOUBLE_EQ(t.call_error.p50_ms, 0.021);
  EXPECT_DOUBLE_EQ(t.call_error.p99_ms, 0.187);
  EXPECT_DOUBLE_EQ(t.to_exposure.p50_ms, 0.390);
  EXPECT_DOUBLE_EQ(t.to_exposure.max_ms, 1.100);

  const std::string name = "camera/corner_front_left";  // the mock rig's longest triggered camera
  const std::string header = trigger_table_header(), row = trigger_table_row(name, t);
  EXPECT_LE(header.size(), 121u) << header;  // 120 columns and the newline
  EXPECT_LE(row.size(), 121u) << row;
  for (const char* column : {"from", "host p50/99", "cam p50/99", "unmatch"})
    EXPECT_NE(header.find(column), std::string::npos) << column << " in " << header;
  for (const char* cell : {"camera/corner_front_left", " device ", "0.412/0.900/1.250", "0.021/0.187", "0.390/0.811"})
    EXPECT_NE(row.find(cell), std::string::npos) << cell << " in " << row;
  EXPECT_LT(row.find("0.021/0.187"), row.find("0.390/0.811"));  // host, then camera, as the header
  EXPECT_EQ(row.substr(row.size() - 3), " 7\n");

  const auto j = trigger_json(name, t);
  EXPECT_EQ(j.at("phase_from"), "device_exposure");
  EXPECT_DOUBLE_EQ(j.at("trigger_call_error_ms").at("p99").get<double>(), 0.187);
  EXPECT_DOUBLE_EQ(j.at("trigger_to_exposure_ms").at("p50").get<double>(), 0.390);
  EXPECT_EQ(j.at("exposure_unmatched"), 7u);
  EXPECT_DOUBLE_EQ(j.at("phase_error_ms").at("p99").get<double>(), 0.900);
}

// A camera that never reported an exposure start (no trigger_to_exposure keys): the phase is the
// trigger call's, the camera's part shown as "-" and absent from the JSON, never a made-up 0.
TEST(TriggerStats, ShowsNoCameraPartWhenTheNodeHasNone) {
  const TriggerStats t = read_trigger_status({{"trigger_lidar", "front"},
                                              {"phase_from", "trigger_call"},
                                              {"trigger_call_error_p50_ms", "0.030"},
                                              {"trigger_call_error_p99_ms", "0.250"}});
  const std::string row = trigger_table_row("camera/stereo_left", t);
  EXPECT_NE(row.find(" call "), std::string::npos) << row;
  EXPECT_NE(row.find(" 0.030/0.250 - "), std::string::npos) << row;
  const auto j = trigger_json("camera/stereo_left", t);
  EXPECT_EQ(j.at("phase_from"), "trigger_call");
  EXPECT_TRUE(j.contains("trigger_call_error_ms"));
  EXPECT_FALSE(j.contains("trigger_to_exposure_ms"));
}

}  // namespace
}  // namespace sensor_rig::rig
