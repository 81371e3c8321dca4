// libFuzzer harness for dds/cdr_view (the zero-copy PointCloud2 / Image readers' parser).
// Input: one selector byte, then the bytes. Selector bit 0: Image instead of PointCloud2; bit 1:
// the bytes are a shared-memory chunk body (no encapsulation header, native order) instead of a
// serialized sample with its 4-byte encapsulation header.
// Invariants: no crash, no read outside the input (ASan); a view that parses has every string
// and span inside the input; the encapsulation decides the byte order.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <span>
#include <string_view>

#include "sensor_rig/dds/cdr_view.hpp"

namespace dds = sensor_rig::dds;

namespace {

bool inside(std::span<const std::byte> part, std::span<const std::byte> whole) {
  return part.empty() || (part.data() >= whole.data() && part.data() + part.size() <= whole.data() + whole.size());
}
bool inside(std::string_view part, std::span<const std::byte> whole) {
  return inside(std::as_bytes(std::span(part.data(), part.size())), whole);
}
void check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t selector = data[0];
  const auto bytes = std::as_bytes(std::span(data + 1, size - 1));
  std::optional<dds::CdrBody> body;
  if ((selector & 2) != 0) {
    body = dds::CdrBody{bytes, std::endian::native};
  } else {
    body = dds::cdr_body(bytes);
    if (!body) return 0;
    check(body->body.size() + 4 == bytes.size());
    check(body->order == (bytes[1] == std::byte{1} ? std::endian::little : std::endian::big));
  }
  if ((selector & 1) != 0) {
    dds::ImageView v;
    if (dds::parse_cdr(*body, v) != dds::CdrStatus::kOk) return 0;
    check(inside(v.header.frame_id, bytes) && inside(v.encoding, bytes) && inside(v.data, bytes));
  } else {
    dds::PointCloud2View v;
    if (dds::parse_cdr(*body, v) != dds::CdrStatus::kOk) return 0;
    check(inside(v.header.frame_id, bytes) && inside(v.data, bytes));
    for (const auto& f : v.fields) check(inside(f.name, bytes));
  }
  return 0;
}
