#pragma once
// Per-message records the load-generator nodes write (CSV) and the runner reads back.
// Publisher CSV  (pub_<node>.csv):  seq,deadline_ns,stamp_ns,write_ns,status
// Subscriber CSV (sub_<node>.csv):  topic,seq,stamp_ns,recv_ns
// Times are CLOCK_REALTIME ns; write_ns is how long the DDS write call took.
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::bench::perf {

// Publisher categories (paper Fig. 11): message i is due at t0 + i/F. On time: written within its own
// period [due, due + 1/F). Late: written later, but before the run ended (t0 + D). Not sent: the run
// ended before the publisher got to it.
enum class SendStatus : std::uint8_t { kOnTime = 0, kLate = 1, kNotSent = 2 };

struct PubRecord {
  std::uint32_t seq = 0;
  Nanos deadline_ns = 0;
  Nanos stamp_ns = 0;  // 0 when not sent
  Nanos write_ns = 0;
  SendStatus status = SendStatus::kNotSent;
};

struct SubRecord {
  std::uint32_t topic = 0;
  std::uint32_t seq = 0;
  Nanos stamp_ns = 0;
  Nanos recv_ns = 0;
};

SendStatus classify_send(Nanos stamp_ns, Nanos due_ns, Nanos period_ns) noexcept;

void write_pub_csv(std::FILE* f, const std::vector<PubRecord>& records);
void write_sub_header(std::FILE* f);
void write_sub_row(std::FILE* f, const SubRecord& r);

// Readers tolerate a truncated last line (a node killed mid-write); they count malformed lines.
struct CsvStats {
  std::size_t rows = 0;
  std::size_t malformed = 0;
};
std::vector<PubRecord> read_pub_csv(const std::string& path, CsvStats* stats = nullptr);
std::vector<SubRecord> read_sub_csv(const std::string& path, CsvStats* stats = nullptr);

}  // namespace sensor_rig::bench::perf
