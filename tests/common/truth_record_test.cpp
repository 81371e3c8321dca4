// The truth record's writer: its lines reach the disk when the writer flushes, in one write() up to
// the buffer it asked for (glibc kept 4 KiB when setvbuf was given no buffer, and after other I/O).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "sensor_rig/common/truth_record.hpp"

namespace sensor_rig::truth {
namespace {

namespace fs = std::filesystem;

// Removes the record however the test ends.
struct RecordFile {
  fs::path path = fs::temp_directory_path() / ("truth_record_test_" + std::to_string(::getpid()) + ".jsonl");
  RecordFile() { fs::remove(path); }
  ~RecordFile() { fs::remove(path); }
  RecordFile(const RecordFile&) = delete;
  RecordFile& operator=(const RecordFile&) = delete;
};

const Header kHeader{"left", "lidar", "OS-LEGACY", "/left/points", "scan", "sensor ns"};

PartRecord part_number(std::uint64_t i) {
  PartRecord r;
  r.seq = i;
  r.unit = static_cast<std::int64_t>(i / 64);
  r.acq_ns = 1'000'000'000 + static_cast<Nanos>(i) * 50'000;
  r.dev_ns = r.acq_ns;
  r.tx_ns = r.acq_ns + 20'000;
  return r;
}

// 500 part lines (~40 KB, 80 bytes each) stay in the stream until
// flush(): well past the 4 KiB a default buffer holds, well within the 64 KiB one asked for.
TEST(TruthRecordWriter, LinesStayBufferedUntilFlushUpToTheRequestedBuffer) {
  RecordFile f;
  Writer w(f.path.string(), kHeader);
  const auto header_bytes = fs::file_size(f.path);
  ASSERT_GT(header_bytes, 0U) << "the header is flushed at once";
  constexpr std::uint64_t kParts = 500;
  for (std::uint64_t i = 0; i < kParts; ++i) w.part(part_number(i));
  EXPECT_EQ(fs::file_size(f.path), header_bytes) << "part lines written out before the flush: the buffer is not the one asked for";
  w.flush();
  EXPECT_GT(fs::file_size(f.path), header_bytes + 32'000);
  const Log log = read(f.path.string());
  ASSERT_EQ(log.parts.size(), kParts);
  EXPECT_EQ(log.parts.back().seq, kParts - 1);
  EXPECT_FALSE(log.cut_last_line);
}

// A predecessor killed mid-line: the restarted writer ends that line before its header (the seek
// between reading the last byte and writing moved with the setvbuf), and both runs read back.
TEST(TruthRecordWriter, ARestartAfterACutLineEndsItBeforeItsHeader) {
  RecordFile f;
  {
    Writer first(f.path.string(), kHeader);
    first.part(part_number(0));
    first.flush();
  }
  {
    std::FILE* cut = std::fopen(f.path.c_str(), "a");
    ASSERT_NE(cut, nullptr);
    std::fputs("{\"p\":1,\"u\":0,\"acq", cut);
    std::fclose(cut);
  }
  {
    Writer second(f.path.string(), kHeader);
    second.part(part_number(0));
    second.flush();
  }
  const Log log = read(f.path.string());
  EXPECT_EQ(log.restarts, 1);
  EXPECT_EQ(log.cut_lines, 1);
  EXPECT_EQ(log.parts.size(), 2U);
}

}  // namespace
}  // namespace sensor_rig::truth
