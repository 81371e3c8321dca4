#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "sensor_rig/lidar/pcd.hpp"

namespace sensor_rig::lidar {
namespace {

constexpr std::size_t kRecord = 23;  // 4*4 + 4 + 2 + 1
constexpr const char* kFields = "FIELDS x y z intensity t ring return_type";
constexpr const char* kSize = "SIZE 4 4 4 4 4 2 1";
constexpr const char* kType = "TYPE F F F F U U U";
constexpr const char* kCount = "COUNT 1 1 1 1 1 1 1";

std::string header(std::size_t n) {
  std::ostringstream h;
  h << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
    << kFields << '\n' << kSize << '\n' << kType << '\n' << kCount << '\n'
    << "WIDTH " << n << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << n << "\nDATA binary\n";
  return h.str();
}

}  // namespace

std::string encode_pcd(std::span<const PointXYZIRT> points) {
  std::string out = header(points.size());
  const std::size_t body = out.size();
  out.resize(body + points.size() * kRecord);
  char* w = out.data() + body;
  for (const auto& p : points) {
    // The in-memory layout is little-endian already (x86/ARM LE); copy field by field to drop
    // the reserved byte.
    std::memcpy(w, &p, 20);  // x y z intensity t
    std::memcpy(w + 20, &p.ring, 2);
    w[22] = static_cast<char>(p.return_type);
    w += kRecord;
  }
  return out;
}

void write_pcd(const std::string& path, std::span<const PointXYZIRT> points) {
  const std::string bytes = encode_pcd(points);
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw PcdError("cannot create " + tmp);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!f.flush()) throw PcdError("cannot write " + tmp);
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) throw PcdError("cannot rename " + tmp + " to " + path);
}

std::vector<PointXYZIRT> decode_pcd(std::string_view bytes, const std::string& source) {
  std::size_t pos = 0;
  std::size_t points = 0;
  bool have_points = false;
  int line_no = 0;
  auto fail = [&](const std::string& what) -> PcdError {
    return PcdError(source + ":" + std::to_string(line_no) + ": " + what);
  };
  for (;;) {
    const auto nl = bytes.find('\n', pos);
    ++line_no;
    if (nl == std::string_view::npos) throw fail("header ends before DATA");
    const std::string_view line = bytes.substr(pos, nl - pos);
    pos = nl + 1;
    if (line.empty() || line[0] == '#') continue;
    const auto sp = line.find(' ');
    const std::string_view key = line.substr(0, sp);
    const std::string_view val = sp == std::string_view::npos ? std::string_view{} : line.substr(sp + 1);
    if (key == "VERSION") {
      if (val != "0.7" && val != ".7") throw fail("unsupported VERSION " + std::string(val));
    } else if (key == "FIELDS" && line != kFields) {
      throw fail("unexpected fields: " + std::string(line));
    } else if (key == "SIZE" && line != kSize) {
      throw fail("unexpected sizes: " + std::string(line));
    } else if (key == "TYPE" && line != kType) {
      throw fail("unexpected types: " + std::string(line));
    } else if (key == "COUNT" && line != kCount) {
      throw fail("unexpected counts: " + std::string(line));
    } else if (key == "POINTS") {
      try {
        points = std::stoull(std::string(val));
      } catch (const std::exception&) {
        throw fail("bad POINTS value");
      }
      have_points = true;
    } else if (key == "DATA") {
      if (val != "binary") throw fail("only DATA binary is supported");
      break;
    }
  }
  if (!have_points) throw fail("no POINTS line");
  const std::size_t body = bytes.size() - pos;
  if (points > body / kRecord || body != points * kRecord) {
    throw PcdError(source + ": body has " + std::to_string(body) + " bytes, " + std::to_string(points) +
                   " points need " + std::to_string(points * kRecord));
  }
  std::vector<PointXYZIRT> out(points);
  const char* r = bytes.data() + pos;
  for (auto& p : out) {
    std::memcpy(&p, r, 20);
    std::memcpy(&p.ring, r + 20, 2);
    p.return_type = static_cast<std::uint8_t>(r[22]);
    p.reserved = 0;
    r += kRecord;
  }
  return out;
}

std::vector<PointXYZIRT> read_pcd(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw PcdError("cannot open " + path);
  std::ostringstream s;
  s << f.rdbuf();
  return decode_pcd(s.str(), path);
}

}  // namespace sensor_rig::lidar
