#include "sensor_rig/bench/perf/records.hpp"

#include <cinttypes>
#include <fstream>
#include <stdexcept>

namespace sensor_rig::bench::perf {

SendStatus classify_send(Nanos stamp_ns, Nanos due_ns, Nanos period_ns) noexcept {
  return stamp_ns - due_ns < period_ns ? SendStatus::kOnTime : SendStatus::kLate;
}

void write_pub_csv(std::FILE* f, const std::vector<PubRecord>& records) {
  std::fputs("seq,deadline_ns,stamp_ns,write_ns,status\n", f);
  for (const auto& r : records) {
    std::fprintf(f, "%" PRIu32 ",%" PRId64 ",%" PRId64 ",%" PRId64 ",%d\n", r.seq, r.deadline_ns, r.stamp_ns,
                 r.write_ns, static_cast<int>(r.status));
  }
}

void write_sub_header(std::FILE* f) { std::fputs("topic,seq,stamp_ns,recv_ns\n", f); }

void write_sub_row(std::FILE* f, const SubRecord& r) {
  std::fprintf(f, "%" PRIu32 ",%" PRIu32 ",%" PRId64 ",%" PRId64 "\n", r.topic, r.seq, r.stamp_ns, r.recv_ns);
}

namespace {
template <class Row, class Parse>
std::vector<Row> read_csv(const std::string& path, CsvStats* stats, Parse parse) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read '" + path + "'");
  std::vector<Row> rows;
  CsvStats st;
  std::string line;
  bool header = true;
  while (std::getline(in, line)) {
    if (header) {
      header = false;
      continue;
    }
    Row r;
    // A last line without its newline was cut by a node killed mid-write: not a record.
    const bool cut = in.eof();
    if (!cut && parse(line, r)) {
      rows.push_back(r);
      ++st.rows;
    } else {
      ++st.malformed;
    }
  }
  if (stats != nullptr) *stats = st;
  return rows;
}
}  // namespace

std::vector<PubRecord> read_pub_csv(const std::string& path, CsvStats* stats) {
  return read_csv<PubRecord>(path, stats, [](const std::string& line, PubRecord& r) {
    int status = -1;
    char tail = 0;
    const int n = std::sscanf(line.c_str(), "%" SCNu32 ",%" SCNd64 ",%" SCNd64 ",%" SCNd64 ",%d%c", &r.seq,
                              &r.deadline_ns, &r.stamp_ns, &r.write_ns, &status, &tail);
    if (n != 5 || status < 0 || status > 2) return false;
    r.status = static_cast<SendStatus>(status);
    return true;
  });
}

std::vector<SubRecord> read_sub_csv(const std::string& path, CsvStats* stats) {
  return read_csv<SubRecord>(path, stats, [](const std::string& line, SubRecord& r) {
    char tail = 0;
    const int n = std::sscanf(line.c_str(), "%" SCNu32 ",%" SCNu32 ",%" SCNd64 ",%" SCNd64 "%c", &r.topic,
                              &r.seq, &r.stamp_ns, &r.recv_ns, &tail);
    return n == 4;
  });
}

}  // namespace sensor_rig::bench::perf
