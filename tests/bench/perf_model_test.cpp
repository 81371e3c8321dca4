// rig perf's pure parts: sizes, plans per topology, statistics, send categories, CSV, the analysis.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <unistd.h>

#include "sensor_rig/bench/perf/analysis.hpp"
#include "sensor_rig/bench/perf/ddsperf.hpp"
#include "sensor_rig/bench/perf/grid.hpp"
#include "sensor_rig/bench/perf/records.hpp"
#include "sensor_rig/bench/perf/roudi.hpp"
#include "sensor_rig/bench/perf/stats.hpp"
#include "sensor_rig/common/cli_context.hpp"

namespace sensor_rig::bench::perf {
namespace {
namespace fs = std::filesystem;

TEST(PerfSpec, SizesAreBinaryMultiples) {
  EXPECT_EQ(parse_size("0B"), 0u);
  EXPECT_EQ(parse_size("16B"), 16u);
  EXPECT_EQ(parse_size("64kB"), 65536u);
  EXPECT_EQ(parse_size("512kB"), 524288u);
  EXPECT_EQ(parse_size("1MB"), 1048576u);
  EXPECT_EQ(parse_size("2MB"), 2097152u);
  EXPECT_EQ(parse_size("PointCloud1m"), 1048576u);
  EXPECT_EQ(size_label(65536), "64kB");
  EXPECT_THROW(parse_size("3MB"), cli::UsageError);
  EXPECT_THROW(parse_transport("tcp"), cli::UsageError);
}

TEST(PerfSpec, PlansFollowTheThreeTopologies) {
  RunSpec s;
  s.nodes = 8;
  s.topology = 1;
  auto p = plan_nodes(s);
  ASSERT_EQ(p.size(), 8u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(p[i].role, Role::kPublisher);
    EXPECT_EQ(p[i].expected_matches, 1);
    EXPECT_EQ(p[4 + i].topics, std::vector<int>{i});
  }
  s.topology = 2;
  p = plan_nodes(s);
  ASSERT_EQ(p.size(), 8u);
  EXPECT_EQ(p[0].expected_matches, 7);
  for (int i = 1; i < 8; ++i) EXPECT_EQ(p[i].topics, std::vector<int>{0});
  s.topology = 3;
  p = plan_nodes(s);
  ASSERT_EQ(p.size(), 8u);
  EXPECT_EQ(p[7].role, Role::kSubscriber);
  EXPECT_EQ(p[7].topics.size(), 7u);
  EXPECT_EQ(p[7].expected_matches, 7);
}

TEST(PerfSpec, ValidationRejectsBadRuns) {
  RunSpec s;
  s.out = "/tmp/x";
  s.topology = 1;
  s.nodes = 3;
  EXPECT_THROW(s.validate(), cli::UsageError);
  s.nodes = 4;
  EXPECT_NO_THROW(s.validate());
  s.rate_hz = 0;
  EXPECT_THROW(s.validate(), cli::UsageError);
  s.rate_hz = 10;
  s.duration_s = 60;
  EXPECT_EQ(s.count(), 600u);
  s.reader = parse_reader_mode("view");  // reads PointCloud2 only
  EXPECT_THROW(s.validate(), cli::UsageError);
  s.message = Message::kPointCloud2;
  EXPECT_NO_THROW(s.validate());
  EXPECT_EQ(s.label(), "T1 N=4 0B 10Hz udp pointcloud2 view");
  EXPECT_THROW(parse_reader_mode("borrow"), cli::UsageError);
}

TEST(PerfStats, PercentilesAndJain) {
  std::vector<double> v;
  for (int i = 100; i >= 1; --i) v.push_back(i);
  const auto s = compute_stats(v);
  EXPECT_EQ(s.n, 100u);
  EXPECT_DOUBLE_EQ(s.mean, 50.5);
  EXPECT_DOUBLE_EQ(s.min, 1);
  EXPECT_DOUBLE_EQ(s.max, 100);
  EXPECT_NEAR(s.p50, 50.5, 1e-9);
  EXPECT_NEAR(s.p99, 99.01, 1e-9);
  EXPECT_NEAR(s.std, 28.866, 1e-3);
  std::vector<double> empty;
  EXPECT_EQ(compute_stats(empty).n, 0u);
  EXPECT_DOUBLE_EQ(jain_index({1, 1, 1, 1}), 1.0);
  EXPECT_DOUBLE_EQ(jain_index({1, 0, 0, 0}), 0.25);
}

TEST(PerfRecords, SendCategoriesByPeriod) {
  EXPECT_EQ(classify_send(1000, 1000, 100), SendStatus::kOnTime);
  EXPECT_EQ(classify_send(1099, 1000, 100), SendStatus::kOnTime);
  EXPECT_EQ(classify_send(1100, 1000, 100), SendStatus::kLate);
}

TEST(PerfRecords, CutLastLineIsNotARecord) {
  const auto p = fs::temp_directory_path() / ("perf_cut_" + std::to_string(::getpid()) + ".csv");
  std::ofstream(p) << "topic,seq,stamp_ns,recv_ns\n0,1,100,200\n0,2,300,4";
  CsvStats st;
  const auto v = read_sub_csv(p.string(), &st);
  ASSERT_EQ(v.size(), 1u);
  EXPECT_EQ(v[0].recv_ns, 200);
  EXPECT_EQ(st.malformed, 1u);
  fs::remove(p);
}

// A synthetic run: topology 2, 3 nodes, 10 messages; node 1 got all, node 2 missed two, has a duplicate,
// a copy of message 9 which the publisher never sent, and message 6 with a stamp that is not the
// publisher's.
TEST(PerfAnalysis, CountsPerSubscriber) {
  const auto dir = fs::temp_directory_path() / ("perf_analysis_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  RunInput in;
  in.spec.topology = 2;
  in.spec.nodes = 3;
  in.spec.rate_hz = 10;
  in.spec.duration_s = 1;
  in.spec.out = dir.string();
  const Nanos t0 = 1'000'000'000'000;
  in.t0_ns = t0;
  std::vector<PubRecord> pub;
  for (std::uint32_t i = 0; i < 10; ++i) {
    const Nanos due = t0 + i * 100'000'000LL;
    PubRecord r{i, due, due + 1000, 500, SendStatus::kOnTime};
    if (i == 9) r = PubRecord{i, due, 0, 0, SendStatus::kNotSent};
    if (i == 8) r.stamp_ns = due + 150'000'000, r.status = SendStatus::kLate;
    pub.push_back(r);
  }
  {
    std::FILE* f = std::fopen((dir / "pub_0.csv").c_str(), "w");
    write_pub_csv(f, pub);
    std::fclose(f);
  }
  for (int node : {1, 2}) {
    std::FILE* f = std::fopen((dir / ("sub_" + std::to_string(node) + ".csv")).c_str(), "w");
    write_sub_header(f);
    for (std::uint32_t i = 0; i < 9; ++i) {
      if (node == 2 && (i == 3 || i == 4)) continue;
      const Nanos lat = (node == 1 ? 1'000'000 : 2'000'000) + (i == 8 ? 200'000'000 : 0);
      const Nanos stamp = node == 2 && i == 6 ? pub[i].stamp_ns - 7 : pub[i].stamp_ns;
      write_sub_row(f, {0, i, stamp, pub[i].stamp_ns + lat});
      if (node == 2 && i == 5) write_sub_row(f, {0, i, pub[i].stamp_ns, pub[i].stamp_ns + lat});
    }
    if (node == 2) write_sub_row(f, {0, 9, pub[8].stamp_ns + 100'000'000, pub[8].stamp_ns + 101'000'000});
    std::fclose(f);
  }
  for (const auto& n : plan_nodes(in.spec)) {
    NodeOutcome o;
    o.plan = n;
    o.pid = 100 + n.index;
    o.exited = true;
    o.exit_code = 0;
    o.max_rss_kb = 1000;
    o.csv = (dir / ((n.role == Role::kPublisher ? "pub_" : "sub_") + std::to_string(n.index) + ".csv")).string();
    in.nodes.push_back(o);
  }
  const auto s = analyse(in);
  EXPECT_EQ(s["sent"], 9);
  EXPECT_EQ(s["sent_on_time"], 8);
  EXPECT_EQ(s["sent_late"], 1);
  EXPECT_EQ(s["not_sent"], 1);
  EXPECT_EQ(s["received"], 9 + 7);
  EXPECT_EQ(s["lost"], 2);
  EXPECT_EQ(s["expected"], 18);
  EXPECT_EQ(s["duplicates"], 1);
  EXPECT_EQ(s["never_sent"], 1);     // message 9: not counted as received, not in the latencies
  EXPECT_EQ(s["per_subscriber"][1]["never_sent"], 1);
  EXPECT_EQ(s["stamp_mismatch"], 1);
  EXPECT_EQ(s["latency_ms"]["n"], 16);
  EXPECT_EQ(s["received_late"], 2);  // message 8 took 200 ms > one period at both
  const std::string warnings = s["warnings"].dump();
  EXPECT_NE(warnings.find("1 duplicate"), std::string::npos) << warnings;
  EXPECT_NE(warnings.find("never_sent"), std::string::npos) << warnings;
  EXPECT_NE(warnings.find("stamp_mismatch"), std::string::npos) << warnings;
  EXPECT_DOUBLE_EQ(s["per_subscriber"][1]["delivery_ratio"].get<double>(), 7.0 / 9.0);
  EXPECT_NEAR(s["fairness"]["jain_delivery_ratio"].get<double>(), (16.0 / 9) * (16.0 / 9) / (2 * (1 + 49.0 / 81)), 1e-12);
  EXPECT_EQ(s["per_subscriber"][0]["lost"], 0);
  EXPECT_EQ(s["per_subscriber"][1]["lost"], 2);
  // Node 1 is always first to receive: mean rank 0; node 2 always last: 1.
  EXPECT_DOUBLE_EQ(s["per_subscriber"][0]["mean_rank"].get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(s["per_subscriber"][1]["mean_rank"].get<double>(), 1.0);
  EXPECT_NEAR(s["latency_ms"]["max"].get<double>(), 202.0, 1e-6);
  EXPECT_TRUE(s["failed_nodes"].empty());
  fs::remove_all(dir);
}

// Topology 3, 3 nodes, 10 messages each: publisher 1 was killed before writing its records, yet its
// subscriber got 4 of its messages. Its 10 messages count as not sent (categories still add up), the
// 4 copies as never_sent, and the summary says the publisher failed.
TEST(PerfAnalysis, FailedPublisherCountsAsNotSent) {
  const auto dir = fs::temp_directory_path() / ("perf_failed_pub_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  RunInput in;
  in.spec.topology = 3;
  in.spec.nodes = 3;
  in.spec.rate_hz = 10;
  in.spec.duration_s = 1;
  in.spec.out = dir.string();
  const Nanos t0 = 1'000'000'000'000;
  std::vector<PubRecord> pub;
  for (std::uint32_t i = 0; i < 10; ++i) pub.push_back({i, t0 + i * 100'000'000LL, t0 + i * 100'000'000LL + 1000, 500, SendStatus::kOnTime});
  {
    std::FILE* f = std::fopen((dir / "pub_0.csv").c_str(), "w");
    write_pub_csv(f, pub);
    std::fclose(f);
    f = std::fopen((dir / "sub_2.csv").c_str(), "w");
    write_sub_header(f);
    for (std::uint32_t topic : {0u, 1u}) {
      for (std::uint32_t i = 0; i < (topic == 0 ? 10u : 4u); ++i) write_sub_row(f, {topic, i, pub[i].stamp_ns, pub[i].stamp_ns + 1'000'000});
    }
    std::fclose(f);
  }
  for (const auto& n : plan_nodes(in.spec)) {
    NodeOutcome o;
    o.plan = n;
    o.pid = 200 + n.index;
    o.exited = true;
    o.exit_code = n.index == 1 ? -1 : 0;
    o.term_signal = n.index == 1 ? 9 : 0;
    o.csv = (dir / ((n.role == Role::kPublisher ? "pub_" : "sub_") + std::to_string(n.index) + ".csv")).string();
    in.nodes.push_back(o);
  }
  const auto s = analyse(in);
  EXPECT_EQ(s["sent"], 10);
  EXPECT_EQ(s["sent_on_time"], 10);
  EXPECT_EQ(s["not_sent"], 10);
  EXPECT_EQ(s["sent_on_time"].get<int>() + s["sent_late"].get<int>() + s["not_sent"].get<int>(), 20);
  EXPECT_EQ(s["received"], 10);
  EXPECT_EQ(s["expected"], 10);
  EXPECT_EQ(s["lost"], 0);
  EXPECT_EQ(s["never_sent"], 4);
  ASSERT_EQ(s["per_publisher"].size(), 2u);
  EXPECT_FALSE(s["per_publisher"][0]["failed"].get<bool>());
  EXPECT_TRUE(s["per_publisher"][1]["failed"].get<bool>());
  EXPECT_EQ(s["per_publisher"][1]["not_sent"], 10);
  EXPECT_FALSE(s["per_publisher"][1]["records"].get<bool>());
  ASSERT_EQ(s["failed_nodes"].size(), 1u);
  EXPECT_EQ(s["failed_nodes"][0]["node"], 1);
  EXPECT_NE(s["warnings"].dump().find("publisher node 1 failed (killed by signal 9)"), std::string::npos) << s["warnings"].dump();
  fs::remove_all(dir);
}

TEST(PerfDdsperf, ParsesPingLines) {
  DdsperfInterval d;
  ASSERT_TRUE(parse_ddsperf_line("[14494] 2.000  vm:14495 size 65536 mean 182.662us min 160.606us 50% 179.894us 90% "
                                 "226.985us 99% 226.985us max 1.5ms cnt 10",
                                 d));
  EXPECT_EQ(d.size, 65536u);
  EXPECT_NEAR(d.mean_us, 182.662, 1e-9);
  EXPECT_NEAR(d.max_us, 1500, 1e-9);
  EXPECT_EQ(d.cnt, 10u);
  EXPECT_FALSE(parse_ddsperf_line("[14494] 3.001  rss:8.6MB vcsw:82 ivcsw:43 ddsperf:1%+0%", d));
  const auto j = aggregate_ddsperf({d, d});
  EXPECT_EQ(j["roundtrips"], 20);
  EXPECT_NEAR(j["one_way_ms_est"]["mean"].get<double>(), 0.182662 / 2, 1e-9);
}

TEST(PerfDdsperf, UnmeasuredSizesAreNamed) {
  DdsperfInterval d;
  ASSERT_TRUE(parse_ddsperf_line("size 16 mean 100us min 90us 50% 100us 90% 110us 99% 120us max 130us cnt 4", d));
  auto measured = aggregate_ddsperf({d});
  measured["size_label"] = "16B";
  auto none = aggregate_ddsperf({});
  none["size_label"] = "1MB";
  EXPECT_TRUE(unmeasured_sizes({{"sizes", {measured}}}).empty());
  EXPECT_EQ(unmeasured_sizes({{"sizes", {measured, none}}}), std::vector<std::string>{"1MB"});
}

TEST(PerfGrid, TablesHaveThePapersCells) {
  GridOptions g;
  g.table = 1;
  g.out = "/tmp/g";
  auto v = grid_specs(g);
  EXPECT_EQ(v.size(), 3u * (1 + 3));  // 3 sizes x (2 nodes once + 32 nodes x 3 topologies)
  g.table = 2;
  v = grid_specs(g);
  EXPECT_EQ(v.size(), 2u * 5u * (1 + 3 * 3));
  g.topologies = {2};
  g.sizes = {"1MB", "2MB"};
  g.rates = {100};
  v = grid_specs(g);
  ASSERT_EQ(v.size(), 8u);
  for (const auto& s : v) EXPECT_EQ(s.rate_hz, 100);
}

TEST(PerfRoudi, ConfigHasAPoolForTheSampleSize) {
  const auto c = roudi_config(2097152, 100);
  EXPECT_NE(c.find("count = 100"), std::string::npos);
  EXPECT_NE(c.find("size = 2098176"), std::string::npos);  // 2 MB + 1 kB headroom, 64-byte multiple
  EXPECT_EQ(roudi_chunks_for(1, 63), 32 + 4 + 252);
}

}  // namespace
}  // namespace sensor_rig::bench::perf
