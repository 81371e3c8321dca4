#include "sensor_rig/record/mcap_reader.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <set>

#include "bytes.hpp"
#include "compression.hpp"
#include "sensor_rig/common/unique_fd.hpp"

namespace sensor_rig::record {
namespace {

constexpr std::size_t kFooterRecord = kRecordHeader + 20;

}  // namespace

McapReader::McapReader(const std::string& path) : path_(path) {
  UniqueFd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (!fd) throw McapError("cannot open " + path + ": " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd.get(), &st) != 0) throw McapError("cannot stat " + path + ": " + std::strerror(errno));
  size_ = static_cast<std::size_t>(st.st_size);
  if (size_ < sizeof kMagic) throw McapError(path + ": not an MCAP file: " + std::to_string(size_) + " bytes, shorter than the magic");
  void* m = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd.get(), 0);
  if (m == MAP_FAILED) throw McapError("cannot map " + path + ": " + std::strerror(errno));
  data_ = static_cast<const std::byte*>(m);
  ::madvise(m, size_, MADV_SEQUENTIAL);
  try {
    scan();
  } catch (...) {
    ::munmap(const_cast<std::byte*>(data_), size_);
    throw;
  }
}

McapReader::~McapReader() {
  if (data_ != nullptr) ::munmap(const_cast<std::byte*>(data_), size_);
}

void McapReader::problem(std::uint64_t offset, std::string what) {
  for (const auto& p : problems_)
    if (p.offset == offset && p.what == what) return;
  problems_.push_back({offset, std::move(what)});
}

bool McapReader::record_schema_or_channel(std::uint8_t op, std::span<const std::byte> body) {
  In in(body);
  if (op == opcode::kSchema) {
    McapSchema s;
    s.id = in.le<std::uint16_t>();
    s.name = in.str();
    s.encoding = in.str();
    s.data = in.str();
    if (!in.ok()) return false;
    schemas_.emplace(s.id, std::move(s));
  } else {
    McapChannel c;
    c.id = in.le<std::uint16_t>();
    c.schema_id = in.le<std::uint16_t>();
    c.topic = in.str();
    c.message_encoding = in.str();
    c.metadata = in.map();
    if (!in.ok()) return false;
    channels_.emplace(c.id, std::move(c));
  }
  return true;
}

void McapReader::scan() {
  if (std::memcmp(data_, kMagic, sizeof kMagic) != 0)
    throw McapError(path_ + ": not an MCAP file: wrong magic at offset 0");
  std::uint64_t pos = sizeof kMagic;
  bool first = true;
  for (;;) {
    if (pos == size_) {
      problem(pos, "the file ends at offset " + std::to_string(pos) + " without DataEnd or Footer (truncated: a recorder that was killed)");
      break;
    }
    if (size_ - pos < kRecordHeader) {
      problem(pos, "truncated record header at offset " + std::to_string(pos));
      break;
    }
    const auto op = std::to_integer<std::uint8_t>(data_[pos]);
    In len_in({data_ + pos + 1, 8});
    const auto len = len_in.le<std::uint64_t>();
    if (len > size_ - pos - kRecordHeader) {
      problem(pos, "record " + hex_op(op) + " at offset " + std::to_string(pos) + " of " + std::to_string(len) +
                       " bytes runs past the end of the file (" + std::to_string(size_) + " bytes): truncated");
      break;
    }
    const std::span<const std::byte> body(data_ + pos + kRecordHeader, len);
    if (first) {
      if (op != opcode::kHeader) throw McapError(path_ + ": not an MCAP file: no Header record at offset 8");
      In h(body);
      profile_ = h.str();
      first = false;
    } else if (op == opcode::kSchema || op == opcode::kChannel) {
      if (!record_schema_or_channel(op, body)) problem(pos, "malformed " + hex_op(op) + " record at offset " + std::to_string(pos));
    } else if (op == opcode::kChunk || op == opcode::kMessage) {
      data_records_.emplace_back(op, pos);
      if (op == opcode::kChunk) ++chunk_count_;
    } else if (op == opcode::kDataEnd || op == opcode::kFooter) {
      break;
    } else if (op == 0 || op == opcode::kHeader) {
      problem(pos, "unexpected record " + hex_op(op) + " at offset " + std::to_string(pos) + ": the rest of the file is not read");
      break;
    }
    pos += kRecordHeader + len;
  }
  // Footer and closing magic at the end; the summary's CRC when given.
  const std::size_t footer = size_ - sizeof kMagic - kFooterRecord;
  if (size_ < sizeof kMagic * 2 + kFooterRecord + 9 ||
      std::memcmp(data_ + size_ - sizeof kMagic, kMagic, sizeof kMagic) != 0 ||
      std::to_integer<std::uint8_t>(data_[footer]) != opcode::kFooter) {
    if (problems_.empty())
      problem(size_, "no Footer and closing magic at the end (offset " + std::to_string(size_) +
                         "): the file is truncated after its data section");
    return;
  }
  In f({data_ + footer + kRecordHeader, 20});
  const auto summary_start = f.le<std::uint64_t>();
  const auto summary_offset_start = f.le<std::uint64_t>();
  const auto crc = f.le<std::uint32_t>();
  if (summary_start > footer || summary_offset_start > footer) {
    problem(footer, "Footer at offset " + std::to_string(footer) + " points past itself");
    return;
  }
  if (summary_start != 0 && crc != 0) {
    const std::span<const std::byte> covered(data_ + summary_start, footer + kRecordHeader + 16 - summary_start);
    if (record::crc32(covered) != crc) {
      problem(summary_start, "summary CRC mismatch (summary at offset " + std::to_string(summary_start) + ")");
      return;
    }
  }
  complete_ = true;
  if (summary_start != 0) read_summary(summary_start, summary_offset_start != 0 ? summary_offset_start : footer);
}

void McapReader::read_summary(std::uint64_t start, std::uint64_t end) {
  std::uint64_t pos = start;
  while (end - pos >= kRecordHeader) {
    const auto op = std::to_integer<std::uint8_t>(data_[pos]);
    In len_in({data_ + pos + 1, 8});
    const auto len = len_in.le<std::uint64_t>();
    if (len > end - pos - kRecordHeader) {
      problem(pos, "summary record at offset " + std::to_string(pos) + " runs past the summary");
      return;
    }
    if (op == opcode::kSchema || op == opcode::kChannel) {
      const std::span<const std::byte> body(data_ + pos + kRecordHeader, len);
      In peek(body);
      const auto id = peek.le<std::uint16_t>();
      const bool known = op == opcode::kSchema ? schemas_.count(id) != 0 : channels_.count(id) != 0;
      if (!known && !record_schema_or_channel(op, body))
        problem(pos, "malformed " + hex_op(op) + " record at offset " + std::to_string(pos));
    } else if (op == opcode::kStatistics) {
      In in({data_ + pos + kRecordHeader, len});
      McapStatistics st;
      st.message_count = in.le<std::uint64_t>();
      in.le<std::uint16_t>();  // schema_count
      in.le<std::uint32_t>();  // channel_count
      in.le<std::uint32_t>();  // attachment_count
      in.le<std::uint32_t>();  // metadata_count
      in.le<std::uint32_t>();  // chunk_count
      st.message_start = in.le<std::uint64_t>();
      st.message_end = in.le<std::uint64_t>();
      In counts(in.bytes(in.le<std::uint32_t>()));
      while (counts.ok() && counts.left() >= 10) {
        const auto id = counts.le<std::uint16_t>();
        st.channel_message_counts[id] = counts.le<std::uint64_t>();
      }
      if (in.ok() && counts.ok() && counts.left() == 0)
        statistics_ = std::move(st);
      else
        problem(pos, "malformed Statistics record at offset " + std::to_string(pos));
    }
    pos += kRecordHeader + len;
  }
}

std::uint64_t McapReader::for_each_message(const std::function<bool(const McapMessage&)>& fn) {
  std::uint64_t n = 0;
  std::vector<std::byte> records;
  struct Entry {
    std::uint64_t log_time;
    std::size_t at;
  };
  std::vector<Entry> order;
  const auto parse_message = [](std::span<const std::byte> body, McapMessage& m) {
    In in(body);
    m.channel_id = in.le<std::uint16_t>();
    m.sequence = in.le<std::uint32_t>();
    m.log_time = in.le<std::uint64_t>();
    m.publish_time = in.le<std::uint64_t>();
    m.data = in.rest();
    return in.ok();
  };
  for (const auto& [op, pos] : data_records_) {
    In rec({data_ + pos + 1, 8});
    const auto len = rec.le<std::uint64_t>();
    const std::span<const std::byte> body(data_ + pos + kRecordHeader, len);
    if (op == opcode::kMessage) {
      McapMessage m;
      if (!parse_message(body, m)) {
        problem(pos, "malformed Message record at offset " + std::to_string(pos));
        continue;
      }
      ++n;
      if (!fn(m)) return n;
      continue;
    }
    In c(body);
    c.le<std::uint64_t>();  // message_start_time
    c.le<std::uint64_t>();  // message_end_time
    const auto uncompressed_size = c.le<std::uint64_t>();
    const auto crc = c.le<std::uint32_t>();
    const std::string compression = c.str();
    const auto records_len = c.le<std::uint64_t>();
    const auto compressed = c.bytes(static_cast<std::size_t>(records_len));
    if (!c.ok() || uncompressed_size > (std::uint64_t{1} << 34)) {
      problem(pos, "malformed Chunk header at offset " + std::to_string(pos) + ": chunk skipped");
      continue;
    }
    try {
      decompress(compression, compressed, static_cast<std::size_t>(uncompressed_size), records);
    } catch (const McapError& e) {
      problem(pos, "chunk at offset " + std::to_string(pos) + " does not decompress (" + e.what() + "): chunk skipped");
      continue;
    }
    if (crc != 0 && record::crc32(records) != crc) {
      problem(pos, "chunk at offset " + std::to_string(pos) + ": CRC mismatch: chunk skipped");
      continue;
    }
    order.clear();
    In r(records);
    bool bad = false;
    while (r.left() > 0) {
      const std::size_t at = r.pos();
      const auto rop = r.le<std::uint8_t>();
      const auto rlen = r.le<std::uint64_t>();
      const auto rbody = r.bytes(static_cast<std::size_t>(std::min<std::uint64_t>(rlen, r.left() + 1)));
      if (!r.ok()) {
        bad = true;
        break;
      }
      if (rop == opcode::kMessage) {
        In t(rbody);
        t.le<std::uint16_t>();
        t.le<std::uint32_t>();
        order.push_back({t.le<std::uint64_t>(), at});
      } else if (rop == opcode::kSchema || rop == opcode::kChannel) {
        In peek(rbody);
        const auto id = peek.le<std::uint16_t>();
        const bool known = rop == opcode::kSchema ? schemas_.count(id) != 0 : channels_.count(id) != 0;
        if (!known) record_schema_or_channel(rop, rbody);
      }
    }
    if (bad) problem(pos, "chunk at offset " + std::to_string(pos) + ": a record runs past the chunk's end: the rest of the chunk skipped");
    std::stable_sort(order.begin(), order.end(), [](const Entry& a, const Entry& b) { return a.log_time < b.log_time; });
    for (const auto& e : order) {
      In hdr(std::span<const std::byte>(records).subspan(e.at + 1, 8));
      const auto mlen = hdr.le<std::uint64_t>();
      McapMessage m;
      if (!parse_message(std::span<const std::byte>(records).subspan(e.at + kRecordHeader, static_cast<std::size_t>(mlen)), m)) {
        problem(pos, "chunk at offset " + std::to_string(pos) + ": malformed Message record");
        continue;
      }
      ++n;
      if (!fn(m)) return n;
    }
  }
  return n;
}

void McapReader::load_channels_from_chunks() {
  for_each_message([](const McapMessage&) { return true; });
}

}  // namespace sensor_rig::record
