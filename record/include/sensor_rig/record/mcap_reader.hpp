#pragma once
// An MCAP reader for `rig play` and the tests: files the rig wrote, files others wrote in the same
// profile (Schema/Channel records in the data section, in chunks or in the summary; chunked or not;
// none | lz4 | zstd), and damaged files. It scans the data section record by record and never
// trusts a length it has not checked against the file: a truncated file (a killed recorder) is read
// up to its last complete record, a chunk whose CRC or decompression fails is skipped; each such
// place is a problem naming its byte offset. Only a file that does not start with MCAP's magic and a
// Header is refused outright.
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "sensor_rig/record/mcap_types.hpp"

namespace sensor_rig::record {

// The summary's Statistics record (when the file has one).
struct McapStatistics {
  std::uint64_t message_count = 0;
  std::uint64_t message_start = 0, message_end = 0;  // log times, ns
  std::map<std::uint16_t, std::uint64_t> channel_message_counts;
};

struct McapProblem {
  std::uint64_t offset = 0;  // byte offset in the file of the record at fault
  std::string what;
};

class McapReader {
 public:
  // Maps the file and scans it (schemas, channels, where the chunks and messages are, the footer and
  // the summary's CRC). Throws McapError naming the file and offset when it is not an MCAP file.
  explicit McapReader(const std::string& path);
  ~McapReader();
  McapReader(const McapReader&) = delete;
  McapReader& operator=(const McapReader&) = delete;

  [[nodiscard]] const std::string& path() const noexcept { return path_; }
  [[nodiscard]] const std::string& profile() const noexcept { return profile_; }
  [[nodiscard]] const std::map<std::uint16_t, McapSchema>& schemas() const noexcept { return schemas_; }
  [[nodiscard]] const std::map<std::uint16_t, McapChannel>& channels() const noexcept { return channels_; }
  // Footer and closing magic present and the summary's CRC (when given) right.
  [[nodiscard]] bool complete() const noexcept { return complete_; }
  [[nodiscard]] const std::vector<McapProblem>& problems() const noexcept { return problems_; }
  [[nodiscard]] std::size_t chunk_count() const noexcept { return chunk_count_; }
  // The summary's Statistics record; nullopt when the file is incomplete or its summary has none.
  [[nodiscard]] const std::optional<McapStatistics>& statistics() const noexcept { return statistics_; }

  // Every readable message: chunks and loose messages in file order, each chunk's messages by log
  // time. fn returns false to stop. Schema/Channel records met inside chunks are added to schemas()
  // and channels() before the messages that follow them. A chunk that cannot be read is added to
  // problems() (once per reader) and skipped. Returns the number of messages passed to fn.
  std::uint64_t for_each_message(const std::function<bool(const McapMessage&)>& fn);
  // Reads every chunk once for its Schema/Channel records (files without a usable summary whose
  // channels are inside chunks: a writer needs them before the first message).
  void load_channels_from_chunks();

 private:
  void scan();
  void read_summary(std::uint64_t start, std::uint64_t end);
  bool record_schema_or_channel(std::uint8_t op, std::span<const std::byte> body);
  void problem(std::uint64_t offset, std::string what);

  std::string path_;
  const std::byte* data_ = nullptr;
  std::size_t size_ = 0;
  std::string profile_;
  bool complete_ = false;
  std::map<std::uint16_t, McapSchema> schemas_;
  std::map<std::uint16_t, McapChannel> channels_;
  std::vector<std::pair<std::uint8_t, std::uint64_t>> data_records_;  // (opcode, offset): chunks and messages
  std::size_t chunk_count_ = 0;
  std::optional<McapStatistics> statistics_;
  std::vector<McapProblem> problems_;
};

}  // namespace sensor_rig::record
