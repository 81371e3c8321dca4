#include "sensor_rig/record/mcap_repair.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <set>
#include <vector>

#include "bytes.hpp"
#include "compression.hpp"
#include "sensor_rig/common/unique_fd.hpp"
#include "sensor_rig/record/mcap_writer.hpp"

namespace sensor_rig::record {
namespace {

std::string op_name(std::uint8_t op) {
  switch (op) {
    case opcode::kSchema: return "Schema";
    case opcode::kChannel: return "Channel";
    case opcode::kMessage: return "Message";
    case opcode::kChunk: return "Chunk";
    case opcode::kMessageIndex: return "Message Index";
    default: return "record " + hex_op(op);
  }
}

class MappedFile {
 public:
  explicit MappedFile(const std::string& path) {
    UniqueFd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
    if (!fd) throw McapError("cannot open " + path + ": " + std::strerror(errno));
    struct stat st {};
    if (::fstat(fd.get(), &st) != 0) throw McapError("cannot stat " + path + ": " + std::strerror(errno));
    size_ = static_cast<std::size_t>(st.st_size);
    if (size_ == 0) return;
    void* m = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd.get(), 0);
    if (m == MAP_FAILED) throw McapError("cannot map " + path + ": " + std::strerror(errno));
    data_ = static_cast<const std::byte*>(m);
    ::madvise(m, size_, MADV_SEQUENTIAL);
  }
  ~MappedFile() {
    if (data_ != nullptr) ::munmap(const_cast<std::byte*>(data_), size_);
  }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  [[nodiscard]] std::span<const std::byte> bytes() const { return {data_, size_}; }

 private:
  const std::byte* data_ = nullptr;
  std::size_t size_ = 0;
};

bool parse_schema(std::span<const std::byte> body, McapSchema& s) {
  In in(body);
  s.id = in.le<std::uint16_t>();
  s.name = in.str();
  s.encoding = in.str();
  s.data = in.str();
  return in.ok();
}

bool parse_channel(std::span<const std::byte> body, McapChannel& c) {
  In in(body);
  c.id = in.le<std::uint16_t>();
  c.schema_id = in.le<std::uint16_t>();
  c.topic = in.str();
  c.message_encoding = in.str();
  c.metadata = in.map();
  return in.ok();
}

// Reads `in` record by record into `w`; returns at the end of the data section or the first damage.
class Repair {
 public:
  Repair(std::span<const std::byte> file, McapWriter& w, RepairResult& r) : file_(file), w_(w), r_(r) {}

  void run(std::uint64_t pos) {
    const std::uint64_t size = file_.size();
    for (;;) {
      r_.stopped_at = pos;
      if (pos == size) return cut("the file ends at offset " + std::to_string(pos) + " without DataEnd (no summary)");
      if (size - pos < kRecordHeader)
        return cut("the record header at offset " + std::to_string(pos) + " is cut by the end of the file (" +
                   std::to_string(size) + " bytes)");
      const auto op = std::to_integer<std::uint8_t>(file_[pos]);
      In len_in(file_.subspan(pos + 1, 8));
      const auto len = len_in.le<std::uint64_t>();
      if (op == 0) return damage("a zero opcode at offset " + std::to_string(pos) + " (not a record)");
      if (len > size - pos - kRecordHeader)
        return cut(op_name(op) + " at offset " + std::to_string(pos) + " of " + std::to_string(len) +
                   " bytes runs past the end of the file (" + std::to_string(size) + " bytes)");
      const auto body = file_.subspan(pos + kRecordHeader, static_cast<std::size_t>(len));
      std::string why;
      switch (op) {
        case opcode::kSchema:
        case opcode::kChannel: why = schema_or_channel(op, body, /*pending=*/false); break;
        case opcode::kChunk: why = chunk(body); break;
        case opcode::kMessage: why = loose_message(body); break;
        case opcode::kDataEnd:
          r_.had_summary = true;
          return;
        case opcode::kFooter: return;  // a file without DataEnd; nothing after it is data
        case opcode::kHeader: why = "a second Header"; break;
        case opcode::kAttachment:
        case opcode::kMetadata: ++r_.skipped_records; break;
        default: break;  // indexes (rebuilt), summary records, private opcodes
      }
      if (!why.empty()) return damage(op_name(op) + " at offset " + std::to_string(pos) + ": " + why);
      pos += kRecordHeader + len;
    }
  }

 private:
  void cut(std::string why) {
    r_.cut = true;
    r_.damage = std::move(why);
  }
  void damage(std::string why) { r_.damage = std::move(why); }

  // Declares a Schema or Channel (now, or `pending` until its chunk has been checked).
  std::string schema_or_channel(std::uint8_t op, std::span<const std::byte> body, bool pending) {
    if (op == opcode::kSchema) {
      McapSchema s;
      if (!parse_schema(body, s)) return "malformed";
      if (s.id == 0) return "schema id 0 is reserved";
      if (schemas_.count(s.id) != 0 || pending_schemas_.count(s.id) != 0) return {};
      if (pending) {
        pending_schemas_.emplace(s.id, std::move(s));
      } else {
        w_.add_schema_as_is(s);
        schemas_.insert(s.id);
        ++r_.schemas;
      }
      return {};
    }
    McapChannel c;
    if (!parse_channel(body, c)) return "malformed";
    if (channels_.count(c.id) != 0 || pending_channels_.count(c.id) != 0) return {};
    if (c.schema_id != 0 && schemas_.count(c.schema_id) == 0 && pending_schemas_.count(c.schema_id) == 0)
      return "channel " + std::to_string(c.id) + " refers to schema " + std::to_string(c.schema_id) + ", never declared";
    if (pending) {
      pending_channels_.emplace(c.id, std::move(c));
    } else {
      w_.add_channel_as_is(c);
      channels_.insert(c.id);
      ++r_.channels;
    }
    return {};
  }

  [[nodiscard]] bool channel_known(std::uint16_t id) const {
    return channels_.count(id) != 0 || pending_channels_.count(id) != 0;
  }

  std::string chunk(std::span<const std::byte> body) {
    In c(body);
    ChunkCopy copy;
    copy.message_start = c.le<std::uint64_t>();
    copy.message_end = c.le<std::uint64_t>();
    copy.uncompressed_size = c.le<std::uint64_t>();
    copy.crc = c.le<std::uint32_t>();
    copy.compression = c.str();
    const auto records_len = c.le<std::uint64_t>();
    if (!c.ok() || records_len > c.left()) return "malformed chunk header";
    copy.records = c.bytes(static_cast<std::size_t>(records_len));
    if (copy.uncompressed_size > (std::uint64_t{1} << 34)) return "an implausible uncompressed size";
    try {
      decompress(copy.compression, copy.records, static_cast<std::size_t>(copy.uncompressed_size), records_);
    } catch (const McapError& e) {
      return std::string("does not decompress (") + e.what() + ")";
    }
    if (copy.crc != 0 && crc32(records_) != copy.crc) return "CRC mismatch";
    pending_schemas_.clear();
    pending_channels_.clear();
    In r(records_);
    while (r.left() > 0) {
      const std::size_t at = r.pos();
      const auto op = r.le<std::uint8_t>();
      const auto len = r.le<std::uint64_t>();
      if (!r.ok() || len > r.left()) return "the record at " + std::to_string(at) + " of its records runs past the chunk's end";
      const auto rbody = r.bytes(static_cast<std::size_t>(len));
      if (op == opcode::kSchema || op == opcode::kChannel) {
        if (auto why = schema_or_channel(op, rbody, /*pending=*/true); !why.empty())
          return op_name(op) + " at " + std::to_string(at) + " of its records: " + why;
      } else if (op == opcode::kMessage) {
        In m(rbody);
        const auto channel = m.le<std::uint16_t>();
        m.le<std::uint32_t>();
        const auto log_time = m.le<std::uint64_t>();
        m.le<std::uint64_t>();
        if (!m.ok()) return "a malformed Message at " + std::to_string(at) + " of its records";
        if (!channel_known(channel))
          return "a Message at " + std::to_string(at) + " of its records on channel " + std::to_string(channel) + ", never declared";
        copy.index[channel].emplace_back(log_time, at);
      }
    }
    // Checked whole: what it declared first, then the chunk as it is.
    for (auto& [id, s] : pending_schemas_) {
      w_.add_schema_as_is(s);
      schemas_.insert(id);
      ++r_.schemas;
    }
    for (auto& [id, ch] : pending_channels_) {
      w_.add_channel_as_is(ch);
      channels_.insert(id);
      ++r_.channels;
    }
    pending_schemas_.clear();
    pending_channels_.clear();
    w_.copy_chunk(copy);
    ++r_.chunks;
    return {};
  }

  std::string loose_message(std::span<const std::byte> body) {
    In m(body);
    const auto channel = m.le<std::uint16_t>();
    const auto sequence = m.le<std::uint32_t>();
    const auto log_time = m.le<std::uint64_t>();
    const auto publish_time = m.le<std::uint64_t>();
    const auto data = m.rest();
    if (!m.ok()) return "malformed";
    if (!channel_known(channel)) return "on channel " + std::to_string(channel) + ", never declared";
    const std::span<const std::byte> pieces[] = {data};
    w_.write(channel, sequence, log_time, publish_time, pieces);
    return {};
  }

  std::span<const std::byte> file_;
  McapWriter& w_;
  RepairResult& r_;
  std::set<std::uint16_t> schemas_, channels_;
  std::map<std::uint16_t, McapSchema> pending_schemas_;
  std::map<std::uint16_t, McapChannel> pending_channels_;
  std::vector<std::byte> records_;
};

}  // namespace

RepairResult repair_mcap(const std::string& in, const std::string& out) {
  const MappedFile file(in);
  const auto bytes = file.bytes();
  if (bytes.size() < sizeof kMagic || std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0)
    throw McapError(in + ": not an MCAP file: wrong magic at offset 0");
  if (bytes.size() < sizeof kMagic + kRecordHeader || std::to_integer<std::uint8_t>(bytes[sizeof kMagic]) != opcode::kHeader)
    throw McapError(in + ": not an MCAP file: no Header record at offset 8");
  In len_in(bytes.subspan(sizeof kMagic + 1, 8));
  const auto header_len = len_in.le<std::uint64_t>();
  if (header_len > bytes.size() - sizeof kMagic - kRecordHeader)
    throw McapError(in + ": the Header record at offset 8 runs past the end of the file: nothing to repair");
  In header(bytes.subspan(sizeof kMagic + kRecordHeader, static_cast<std::size_t>(header_len)));
  McapWriterOptions o;
  o.profile = header.str();
  o.library = header.str();
  if (!header.ok()) throw McapError(in + ": malformed Header record at offset 8");

  RepairResult r;
  r.input_bytes = bytes.size();
  McapWriter w(out, o);
  Repair(bytes, w, r).run(sizeof kMagic + kRecordHeader + header_len);
  w.close();
  r.messages = w.stats().messages;
  r.output_bytes = w.stats().file_bytes;
  return r;
}

}  // namespace sensor_rig::record
