#include "sensor_rig/record/mcap_writer.hpp"

#include <fcntl.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "bytes.hpp"
#include "compression.hpp"
#include "sensor_rig/common/clock.hpp"

namespace sensor_rig::record {

McapWriter::McapWriter(const std::string& path, McapWriterOptions options)
    : path_(path), opt_(std::move(options)), compressor_(std::make_unique<Compressor>(opt_.compression, opt_.zstd_level)) {
  fd_.reset(::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
  if (!fd_) throw McapError("cannot create " + path + ": " + std::strerror(errno));
  std::vector<std::byte> b(std::begin(kMagic), std::end(kMagic));
  Out o(b);
  const auto at = o.begin_record(opcode::kHeader);
  o.str(opt_.profile);
  o.str(opt_.library);
  o.end_record(at);
  write_out(b);
  chunk_.reserve(opt_.chunk_size + (1 << 20));
}

McapWriter::~McapWriter() {
  if (!closed_ && fd_) {
    try {
      close();
    } catch (const McapError&) {
      // The owner did not call close(); what reached the file stays readable up to the last chunk.
    }
  }
}

void McapWriter::write_out(std::span<const std::span<const std::byte>> pieces) {
  constexpr std::size_t kMaxIov = 8;
  iovec iov[kMaxIov];
  std::size_t n = 0;
  for (const auto& p : pieces)
    if (!p.empty() && n < kMaxIov) iov[n++] = iovec{const_cast<std::byte*>(p.data()), p.size()};
  const Nanos t0 = monotonic_now_ns();
  std::size_t first = 0;
  while (first < n) {
    const ssize_t w = ::writev(fd_.get(), iov + first, static_cast<int>(n - first));
    if (w < 0) {
      if (errno == EINTR) continue;
      throw McapError("write to " + path_ + " failed at offset " + std::to_string(offset_) + ": " + std::strerror(errno));
    }
    offset_ += static_cast<std::uint64_t>(w);
    auto left = static_cast<std::size_t>(w);
    while (first < n && left >= iov[first].iov_len) left -= iov[first++].iov_len;
    if (first < n) {
      iov[first].iov_base = static_cast<char*>(iov[first].iov_base) + left;
      iov[first].iov_len -= left;
    }
  }
  stats_.write_ns += monotonic_now_ns() - t0;
  stats_.file_bytes = offset_;
}

void McapWriter::write_schema_record(const McapSchema& s) {
  std::vector<std::byte> b;
  Out o(b);
  const auto at = o.begin_record(opcode::kSchema);
  o.le(s.id);
  o.str(s.name);
  o.str(s.encoding);
  o.str(s.data);  // bytes: uint32 length + bytes, as a string
  o.end_record(at);
  write_out(b);
}

void McapWriter::write_channel_record(const McapChannel& c) {
  std::vector<std::byte> b;
  Out o(b);
  const auto at = o.begin_record(opcode::kChannel);
  o.le(c.id);
  o.le(c.schema_id);
  o.str(c.topic);
  o.str(c.message_encoding);
  o.map(c.metadata);
  o.end_record(at);
  write_out(b);
}

std::uint16_t McapWriter::add_schema(const std::string& name, const std::string& encoding, const std::string& data) {
  if (schemas_.size() >= 0xfffe) throw McapError("too many schemas");
  add_schema_as_is(McapSchema{static_cast<std::uint16_t>(schemas_.size() + 1), name, encoding, data});
  return schemas_.back().id;
}

std::uint16_t McapWriter::add_channel(std::uint16_t schema_id, const std::string& topic,
                                      const std::string& message_encoding,
                                      const std::map<std::string, std::string>& metadata) {
  if (channels_.size() >= 0xfffe) throw McapError("too many channels");
  add_channel_as_is(McapChannel{static_cast<std::uint16_t>(channels_.size() + 1), schema_id, topic, message_encoding, metadata});
  return channels_.back().id;
}

void McapWriter::add_schema_as_is(const McapSchema& s) {
  write_schema_record(s);
  schemas_.push_back(s);
}

void McapWriter::add_channel_as_is(const McapChannel& c) {
  write_channel_record(c);
  channels_.push_back(c);
}

void McapWriter::count_message(std::uint16_t channel_id, std::uint64_t log_time) {
  if (stats_.messages == 0) stats_.message_start = stats_.message_end = log_time;
  stats_.message_start = std::min(stats_.message_start, log_time);
  stats_.message_end = std::max(stats_.message_end, log_time);
  ++stats_.messages;
  ++channel_counts_[channel_id];
}

void McapWriter::write(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time,
                       std::uint64_t publish_time, std::span<const std::span<const std::byte>> pieces) {
  std::size_t size = 0;
  for (const auto& p : pieces) size += p.size();
  const std::uint64_t at = chunk_.size();
  Out o(chunk_);
  o.le(opcode::kMessage);
  o.le(static_cast<std::uint64_t>(2 + 4 + 8 + 8 + size));
  o.le(channel_id);
  o.le(sequence);
  o.le(log_time);
  o.le(publish_time);
  for (const auto& p : pieces) o.raw(p);
  chunk_index_[channel_id].emplace_back(log_time, at);
  if (at == 0) chunk_start_ = chunk_end_ = log_time;
  chunk_start_ = std::min(chunk_start_, log_time);
  chunk_end_ = std::max(chunk_end_, log_time);
  count_message(channel_id, log_time);
  stats_.uncompressed_bytes += chunk_.size() - at;
  if (chunk_.size() >= opt_.chunk_size) flush_chunk();
}

void McapWriter::flush_chunk() {
  if (chunk_.empty()) return;
  const Nanos t0 = monotonic_now_ns();
  const std::uint32_t crc = crc32(chunk_);
  // Uncompressed chunks are written from chunk_ itself (no copy).
  const bool raw = opt_.compression == Compression::kNone;
  if (!raw) compressor_->compress(chunk_, compressed_);
  const std::span<const std::byte> records = raw ? std::span<const std::byte>(chunk_) : std::span<const std::byte>(compressed_);
  stats_.compress_ns += monotonic_now_ns() - t0;

  write_chunk(chunk_start_, chunk_end_, chunk_.size(), crc, mcap_name(opt_.compression), records, chunk_index_);
  chunk_.clear();
  chunk_index_.clear();
}

void McapWriter::copy_chunk(ChunkCopy& c) {
  flush_chunk();
  for (const auto& [channel, entries] : c.index)
    for (const auto& e : entries) count_message(channel, e.first);
  stats_.uncompressed_bytes += c.uncompressed_size;
  write_chunk(c.message_start, c.message_end, c.uncompressed_size, c.crc, c.compression, c.records, c.index);
}

void McapWriter::write_chunk(std::uint64_t start, std::uint64_t end, std::uint64_t uncompressed_size, std::uint32_t crc,
                             std::string_view comp, std::span<const std::byte> records,
                             std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>>& index) {
  // Chunk record: header fields, then the records' u64 length and bytes (written from `records`).
  scratch_.clear();
  Out h(scratch_);
  const std::uint64_t content = 8 + 8 + 8 + 4 + 4 + comp.size() + 8 + records.size();
  h.le(opcode::kChunk);
  h.le(content);
  h.le(start);
  h.le(end);
  h.le(uncompressed_size);
  h.le(crc);
  h.str(comp);
  h.le(static_cast<std::uint64_t>(records.size()));
  const std::uint64_t chunk_offset = offset_;
  const std::uint64_t chunk_length = scratch_.size() + records.size();
  const std::size_t header_size = scratch_.size();

  // Message Index records, one per channel, right after the chunk (in the same write).
  std::map<std::uint16_t, std::uint64_t> index_offsets;
  for (auto& [channel, entries] : index) {
    std::stable_sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    index_offsets[channel] = chunk_offset + chunk_length + (scratch_.size() - header_size);
    Out m(scratch_);
    const auto at = m.begin_record(opcode::kMessageIndex);
    m.le(channel);
    m.le(static_cast<std::uint32_t>(entries.size() * 16));
    for (const auto& [t, off] : entries) {
      m.le(t);
      m.le(off);
    }
    m.end_record(at);
  }
  const std::uint64_t index_length = scratch_.size() - header_size;
  const std::span<const std::byte> all(scratch_);
  const std::span<const std::byte> pieces[] = {all.first(header_size), records, all.subspan(header_size)};
  write_out(pieces);

  Out ci(chunk_indexes_);
  const auto at = ci.begin_record(opcode::kChunkIndex);
  ci.le(start);
  ci.le(end);
  ci.le(chunk_offset);
  ci.le(chunk_length);
  ci.le(static_cast<std::uint32_t>(index_offsets.size() * 10));
  for (const auto& [channel, off] : index_offsets) {
    ci.le(channel);
    ci.le(off);
  }
  ci.le(index_length);
  ci.str(comp);
  ci.le(static_cast<std::uint64_t>(records.size()));
  ci.le(uncompressed_size);
  ci.end_record(at);
  ++stats_.chunks;
}

void McapWriter::close() {
  if (closed_) return;
  closed_ = true;  // a failure below leaves the file as far as it got; no second attempt
  flush_chunk();
  std::vector<std::byte> b;
  Out o(b);
  auto at = o.begin_record(opcode::kDataEnd);
  o.le(std::uint32_t{0});  // data section CRC not computed (allowed: 0); each chunk has its own
  o.end_record(at);

  const std::uint64_t summary_start = offset_ + b.size();
  struct Group {
    std::uint8_t op;
    std::uint64_t start, length;
  };
  std::vector<Group> groups;
  const auto group = [&](std::uint8_t op, std::size_t from) {
    if (b.size() > from) groups.push_back({op, offset_ + from, b.size() - from});
  };
  std::size_t from = b.size();
  for (const auto& s : schemas_) {
    at = o.begin_record(opcode::kSchema);
    o.le(s.id);
    o.str(s.name);
    o.str(s.encoding);
    o.str(s.data);
    o.end_record(at);
  }
  group(opcode::kSchema, from);
  from = b.size();
  for (const auto& c : channels_) {
    at = o.begin_record(opcode::kChannel);
    o.le(c.id);
    o.le(c.schema_id);
    o.str(c.topic);
    o.str(c.message_encoding);
    o.map(c.metadata);
    o.end_record(at);
  }
  group(opcode::kChannel, from);
  from = b.size();
  at = o.begin_record(opcode::kStatistics);
  o.le(stats_.messages);
  o.le(static_cast<std::uint16_t>(schemas_.size()));
  o.le(static_cast<std::uint32_t>(channels_.size()));
  o.le(std::uint32_t{0});  // attachments
  o.le(std::uint32_t{0});  // metadata
  o.le(static_cast<std::uint32_t>(stats_.chunks));
  o.le(stats_.message_start);
  o.le(stats_.message_end);
  o.le(static_cast<std::uint32_t>(channel_counts_.size() * 10));
  for (const auto& [id, n] : channel_counts_) {
    o.le(id);
    o.le(n);
  }
  o.end_record(at);
  group(opcode::kStatistics, from);
  from = b.size();
  o.raw(chunk_indexes_);
  group(opcode::kChunkIndex, from);

  const std::uint64_t summary_offset_start = offset_ + b.size();
  for (const auto& g : groups) {
    at = o.begin_record(opcode::kSummaryOffset);
    o.le(g.op);
    o.le(g.start);
    o.le(g.length);
    o.end_record(at);
  }
  o.le(opcode::kFooter);
  o.le(std::uint64_t{8 + 8 + 4});
  o.le(summary_start);
  o.le(summary_offset_start);
  const std::size_t summary_in_b = static_cast<std::size_t>(summary_start - offset_);
  const std::uint32_t crc = crc32(std::span<const std::byte>(b).subspan(summary_in_b, b.size() - summary_in_b));
  o.le(crc);
  o.raw(std::span<const std::byte>(kMagic));
  write_out(b);
  if (::close(fd_.release()) != 0)
    throw McapError("closing " + path_ + ": " + std::strerror(errno));
}

}  // namespace sensor_rig::record
