#include "sensor_rig/common/truth_record.hpp"

#include <array>
#include <cinttypes>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

namespace sensor_rig::truth {
namespace {

constexpr std::array<std::string_view, 7> kFates{"sent", "dropped", "corrupted", "duplicated", "delayed", "not_sent", "truncated"};

// JSON string escaping for the few free-text fields (names, details): quotes, backslashes, controls.
std::string escaped(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
      out += buf;
    } else {
      out += c;
    }
  }
  return out;
}

}  // namespace

std::string_view to_string(Fate f) noexcept { return kFates[static_cast<std::size_t>(f)]; }

bool parse_fate(std::string_view s, Fate& out) noexcept {
  for (std::size_t i = 0; i < kFates.size(); ++i)
    if (kFates[i] == s) {
      out = static_cast<Fate>(i);
      return true;
    }
  return false;
}

Writer::Writer(const std::string& path, const Header& h) : path_(path) {
  // Appending: a mock killed and restarted (host.kill_mock) continues its device's record after a new
  // header; the reader keeps the two runs' unit ids apart.
  file_ = std::fopen(path.c_str(), "a+");
  if (file_ == nullptr) throw std::runtime_error("cannot create truth record " + path);
  // Before any other operation on the stream (setvbuf after the fseek below is undefined), and with a
  // buffer of our own: glibc ignores the size when given none and keeps st_blksize (4 KiB), so a batch
  // of lines went out in several write()s, the last line of one often split across two. The writers
  // still decide when the lines are on disk (flush()); this only bounds the writes between flushes.
  buffer_ = std::make_unique<char[]>(kBufferBytes);
  std::setvbuf(file_, buffer_.get(), _IOFBF, kBufferBytes);
  // A predecessor killed mid-line left it unterminated: end it, so that our header is a line of its own.
  // The seek between the read and the write is the one the standard requires there.
  if (std::fseek(file_, -1, SEEK_END) == 0) {
    const int last = std::fgetc(file_);
    std::fseek(file_, 0, SEEK_END);
    if (last != '\n') std::fputc('\n', file_);
  }
  const std::string line = "{\"truth\":1,\"device\":\"" + escaped(h.device) + "\",\"class\":\"" + escaped(h.device_class) +
                           "\",\"model\":\"" + escaped(h.model) + "\",\"topic\":\"" + escaped(h.topic) + "\",\"unit\":\"" +
                           escaped(h.unit) + "\",\"clock\":\"" + escaped(h.clock) + "\"}\n";
  put(line.data(), static_cast<int>(line.size()));
  flush();  // the header is there even if the mock dies at once
}

Writer::~Writer() {
  if (file_ != nullptr) std::fclose(file_);
}

void Writer::put(const char* line, int n) {
  std::lock_guard lock(mutex_);
  std::fwrite(line, 1, static_cast<std::size_t>(n), file_);
  ++lines_;
}

void Writer::unit(const UnitRecord& r) {
  char buf[160];
  const int n = r.exposure_ns > 0
                    ? std::snprintf(buf, sizeof buf, "{\"u\":%" PRId64 ",\"acq\":%" PRId64 ",\"dev\":%" PRId64 ",\"parts\":%" PRIu32 ",\"exp\":%" PRId64 "}\n",
                                    r.unit, r.acq_ns, r.dev_ns, r.parts, r.exposure_ns)
                    : std::snprintf(buf, sizeof buf, "{\"u\":%" PRId64 ",\"acq\":%" PRId64 ",\"dev\":%" PRId64 ",\"parts\":%" PRIu32 "}\n",
                                    r.unit, r.acq_ns, r.dev_ns, r.parts);
  put(buf, n);
}

void Writer::part(const PartRecord& r) {
  char buf[224];
  int n = std::snprintf(buf, sizeof buf,
                        "{\"p\":%" PRIu64 ",\"u\":%" PRId64 ",\"acq\":%" PRId64 ",\"dev\":%" PRId64 ",\"tx\":%" PRId64 ",\"fate\":\"%s\"",
                        r.seq, r.unit, r.acq_ns, r.dev_ns, r.tx_ns, to_string(r.fate).data());
  if (r.fault != 0) n += std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n), ",\"fault\":%" PRIu64, r.fault);
  if (r.unit_last > r.unit) n += std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n), ",\"u2\":%" PRId64, r.unit_last);
  n += std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n), "}\n");
  put(buf, n);
}

void Writer::fault(const FaultRecord& r) {
  char buf[160];
  const int n = std::snprintf(buf, sizeof buf, "{\"f\":%" PRIu64 ",\"at\":%" PRId64 ",\"until\":%" PRId64 ",\"u\":%" PRId64 ",",
                              r.id, r.at_ns, r.until_ns, r.unit);
  const std::string line =
      std::string(buf, static_cast<std::size_t>(n)) + "\"kind\":\"" + escaped(r.kind) + "\",\"detail\":\"" + escaped(r.detail) + "\"}\n";
  put(line.data(), static_cast<int>(line.size()));
}

void Writer::flush() {
  std::lock_guard lock(mutex_);
  std::fflush(file_);
}

std::unique_ptr<Writer> open_if(const std::string& path, const Header& header) {
  if (path.empty()) return nullptr;
  return std::make_unique<Writer>(path, header);
}

Log read(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read truth record " + path);
  Log log;
  std::string line;
  int n = 0;
  bool have_header = false;
  std::int64_t unit_offset = 0;  // per restart of the writer: its unit ids start again
  while (std::getline(in, line)) {
    ++n;
    if (line.empty()) continue;
    const bool last = in.peek() == std::char_traits<char>::eof();
    nlohmann::json j = nlohmann::json::parse(line, nullptr, false);
    if (j.is_discarded()) {
      // A writer killed mid-line: the line never happened. It is the last line, or the mock was
      // restarted and its new header follows.
      const bool restart_follows = !last && in.peek() == '{' && [&] {
        const auto pos = in.tellg();
        std::string next;
        std::getline(in, next);
        in.seekg(pos);
        return next.rfind("{\"truth\"", 0) == 0;
      }();
      if (last || restart_follows) {
        log.cut_last_line = true;
        ++log.cut_lines;
        continue;
      }
      throw std::runtime_error(path + ":" + std::to_string(n) + ": not a JSON object: " + line.substr(0, 80));
    }
    try {
      if (have_header && j.contains("truth")) {
        unit_offset += std::int64_t{1} << 40;
        ++log.restarts;
      } else if (!have_header) {
        if (!j.contains("truth")) throw std::runtime_error("not a truth record (no \"truth\" header)");
        log.header = Header{j.value("device", ""), j.value("class", ""), j.value("model", ""),
                            j.value("topic", ""), j.value("unit", ""), j.value("clock", "")};
        have_header = true;
      } else if (j.contains("p")) {
        PartRecord r;
        r.seq = j.at("p").get<std::uint64_t>();
        r.unit = j.at("u").get<std::int64_t>() + unit_offset;
        r.acq_ns = j.at("acq").get<Nanos>();
        r.dev_ns = j.value("dev", Nanos{0});
        r.tx_ns = j.value("tx", Nanos{0});
        if (!parse_fate(j.at("fate").get<std::string>(), r.fate)) throw std::runtime_error("unknown fate");
        r.fault = j.value("fault", std::uint64_t{0});
        if (j.contains("u2")) r.unit_last = j.at("u2").get<std::int64_t>() + unit_offset;
        log.parts.push_back(r);
      } else if (j.contains("f")) {
        const std::int64_t u = j.value("u", std::int64_t{-1});
        log.faults.push_back(FaultRecord{j.at("f").get<std::uint64_t>(), j.at("kind").get<std::string>(), j.at("at").get<Nanos>(),
                                         j.value("until", Nanos{0}), u < 0 ? u : u + unit_offset, j.value("detail", "")});
      } else if (j.contains("u")) {
        log.units.push_back(UnitRecord{j.at("u").get<std::int64_t>() + unit_offset, j.at("acq").get<Nanos>(), j.value("dev", Nanos{0}),
                                       j.value("parts", std::uint32_t{0}), j.value("exp", Nanos{0})});
      } else {
        throw std::runtime_error("neither a unit, a part nor a fault");
      }
    } catch (const nlohmann::json::exception& e) {
      throw std::runtime_error(path + ":" + std::to_string(n) + ": " + e.what());
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(path + ":" + std::to_string(n) + ": " + e.what());
    }
  }
  if (!have_header) throw std::runtime_error(path + ": empty truth record");
  return log;
}

}  // namespace sensor_rig::truth
