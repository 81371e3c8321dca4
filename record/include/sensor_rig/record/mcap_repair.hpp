#pragma once
// Makes a complete, indexed MCAP file of what is intact in a damaged one (a recorder killed before
// its summary, a cut copy, a corrupt chunk): the data section is read record by record from the
// start and reading stops at the first damaged byte (a record running past the end of the file, a
// chunk whose CRC, decompression or records are wrong, a message on a channel never declared, a
// zero opcode). Everything before it is written again: Schema and Channel records (also those met
// inside chunks) keeping their ids, each intact chunk copied as it is compressed (not recompressed:
// the speed is that of decompressing to check the CRC), its Message Index records rebuilt, loose
// messages into new chunks, then DataEnd and a summary (Schemas, Channels, Statistics, Chunk
// Indexes, Summary Offsets) and the Footer, as McapWriter writes them.
#include <cstdint>
#include <string>

namespace sensor_rig::record {

struct RepairResult {
  std::uint64_t input_bytes = 0;
  std::uint64_t stopped_at = 0;      // offset where reading stopped: the first damaged byte, or DataEnd
  std::string damage;                // what is wrong at stopped_at; empty when nothing was
  bool cut = false;                  // the damage is the end of the file (a killed writer or a cut copy)
  bool had_summary = false;          // DataEnd was reached: the input's data section is whole
  std::uint64_t messages = 0, chunks = 0, schemas = 0, channels = 0;
  std::uint64_t skipped_records = 0;  // Attachment / Metadata records not carried over
  std::uint64_t output_bytes = 0;
};

// Reads `in` and writes `out` (created or truncated; must be another file). Throws McapError when
// `in` is not an MCAP file (no magic and Header) or `out` cannot be written.
RepairResult repair_mcap(const std::string& in, const std::string& out);

}  // namespace sensor_rig::record
