#pragma once
// An MCAP writer (https://mcap.dev/spec): magic, Header, Schema and Channel records in the data
// section as they are added, messages in Chunks (none | lz4 | zstd, CRC-32 of the uncompressed
// records) each followed at once by its Message Index records, then DataEnd and a summary
// (Schemas, Channels, Statistics, Chunk Indexes, Summary Offsets) and the Footer with the summary's
// CRC. A chunk and its indexes are written as soon as the chunk is full, before any later message:
// a writer killed mid-file leaves every completed chunk readable (McapReader reads up to the last
// good one; the summary and the chunk being filled are what is lost).
#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "sensor_rig/common/unique_fd.hpp"
#include "sensor_rig/record/mcap_types.hpp"

namespace sensor_rig::record {

class Compressor;

struct McapWriterOptions {
  std::string profile = "ros2";
  std::string library = "sensor-rig";
  Compression compression = Compression::kZstd;
  std::size_t chunk_size = 4 << 20;  // uncompressed record bytes per chunk before it is written
  int zstd_level = 1;                // 1: ~4x realtime for camera images on one core of this VM
};

struct McapWriterStats {
  std::uint64_t messages = 0;
  std::uint64_t chunks = 0;
  std::uint64_t uncompressed_bytes = 0;  // message records before compression
  std::uint64_t file_bytes = 0;          // written to the file so far
  std::int64_t compress_ns = 0;          // time spent compressing and checksumming
  std::int64_t write_ns = 0;             // time spent in write(2)
  std::uint64_t message_start = 0, message_end = 0;  // log times of the first and last message (ns)
};

// A chunk copied as it is from another file (`repair_mcap`): its records compressed as they were,
// and where its messages lie in the uncompressed records, for its Message Index records.
struct ChunkCopy {
  std::uint64_t message_start = 0, message_end = 0, uncompressed_size = 0;
  std::uint32_t crc = 0;
  std::string compression;              // "", "lz4", "zstd"
  std::span<const std::byte> records;   // as compressed in the source
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> index;  // channel -> (log time, offset)
};

class McapWriter {
 public:
  // Creates (truncates) `path` and writes the magic and the Header. Throws McapError with the reason.
  McapWriter(const std::string& path, McapWriterOptions options);
  // Closes the file properly if close() was not called; errors are swallowed (call close()).
  ~McapWriter();
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  // Ids from 1, in the order added. Written to the file at once. Throws McapError.
  std::uint16_t add_schema(const std::string& name, const std::string& encoding, const std::string& data);
  std::uint16_t add_channel(std::uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                            const std::map<std::string, std::string>& metadata);
  // A schema / channel keeping its id (a copy of another file's; do not mix with the two above).
  void add_schema_as_is(const McapSchema& s);
  void add_channel_as_is(const McapChannel& c);
  // Writes the chunk being filled, then `c` with Message Index records made from c.index.
  void copy_chunk(ChunkCopy& c);
  // One message whose data is the concatenation of `pieces`. Writes the chunk when it is full.
  // Throws McapError on a write error (e.g. ENOSPC); the file then holds every chunk completed before.
  void write(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time, std::uint64_t publish_time,
             std::span<const std::span<const std::byte>> pieces);
  // Writes the chunk being filled (if any). Throws McapError.
  void flush_chunk();
  // The last chunk, DataEnd, the summary, the Footer and the closing magic. Throws McapError.
  void close();

  [[nodiscard]] const McapWriterStats& stats() const noexcept { return stats_; }
  // Messages per channel id so far.
  [[nodiscard]] const std::map<std::uint16_t, std::uint64_t>& channel_counts() const noexcept { return channel_counts_; }
  [[nodiscard]] const std::string& path() const noexcept { return path_; }
  // Bytes in the chunk being filled (not yet in the file).
  [[nodiscard]] std::size_t pending_bytes() const noexcept { return chunk_.size(); }

 private:
  void write_out(std::span<const std::span<const std::byte>> pieces);
  void write_schema_record(const McapSchema& s);
  void write_channel_record(const McapChannel& c);
  // The Chunk record around `records` (compressed as `comp`), its Message Index records, its Chunk Index.
  void write_chunk(std::uint64_t start, std::uint64_t end, std::uint64_t uncompressed_size, std::uint32_t crc,
                   std::string_view comp, std::span<const std::byte> records,
                   std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>>& index);
  void count_message(std::uint16_t channel_id, std::uint64_t log_time);
  void write_out(std::span<const std::byte> b) {
    const std::span<const std::byte> one[] = {b};
    write_out(one);
  }

  std::string path_;
  McapWriterOptions opt_;
  UniqueFd fd_;
  bool closed_ = false;
  std::unique_ptr<Compressor> compressor_;
  std::uint64_t offset_ = 0;  // file offset of the next byte written
  std::vector<McapSchema> schemas_;
  std::vector<McapChannel> channels_;
  // The chunk being filled: its records, and per channel (log_time, offset in records).
  std::vector<std::byte> chunk_;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;
  std::uint64_t chunk_start_ = 0, chunk_end_ = 0;
  std::vector<std::byte> compressed_, scratch_;
  std::vector<std::byte> chunk_indexes_;  // ChunkIndex records for the summary, as written
  std::map<std::uint16_t, std::uint64_t> channel_counts_;
  McapWriterStats stats_;
};

}  // namespace sensor_rig::record
