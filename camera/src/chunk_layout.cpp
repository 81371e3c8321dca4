#include "chunk_layout.hpp"

#include <bit>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "aravis_internal.hpp"  // take_error

namespace sensor_rig::camera::detail {
namespace {

// The field's bytes as an unsigned number in host order; nullopt outside the chunk.
std::optional<std::uint64_t> raw_bits(const ChunkSpan& chunk, const ChunkField& field) {
  if (field.length == 0 || field.length > 8 || field.offset > chunk.size || chunk.size - field.offset < field.length) return std::nullopt;
  const std::uint8_t* p = chunk.data + field.offset;
  std::uint64_t v = 0;
  for (std::uint32_t i = 0; i < field.length; ++i) {
    const std::uint32_t byte = field.big_endian ? i : field.length - 1 - i;  // most significant first
    v = (v << 8) | p[byte];
  }
  return v;
}

std::optional<double> as_float(std::uint64_t bits, std::uint32_t length) {
  if (length == 8) return std::bit_cast<double>(bits);
  if (length == 4) return static_cast<double>(std::bit_cast<float>(static_cast<std::uint32_t>(bits)));
  return std::nullopt;  // a FloatReg of another length is not IEEE 754
}

std::int64_t as_integer(std::uint64_t bits, const ChunkField& field) {
  if (!field.is_signed || field.length == 8) return static_cast<std::int64_t>(bits);
  const std::uint64_t sign = std::uint64_t{1} << (8 * field.length - 1);
  return static_cast<std::int64_t>((bits ^ sign) - sign);  // sign-extend from the field's width
}

// The first child of `node` that is a property of `type` (pValue, pPort, ChunkID, Endianess, …).
ArvGcPropertyNode* child_property(ArvGcNode* node, ArvGcPropertyNodeType type) {
  for (ArvDomNode* c = arv_dom_node_get_first_child(ARV_DOM_NODE(node)); c != nullptr; c = arv_dom_node_get_next_sibling(c))
    if (ARV_IS_GC_PROPERTY_NODE(c) && arv_gc_property_node_get_node_type(ARV_GC_PROPERTY_NODE(c)) == type) return ARV_GC_PROPERTY_NODE(c);
  return nullptr;
}

}  // namespace

std::optional<ChunkSpan> find_chunk(const std::uint8_t* data, std::size_t size, std::uint32_t id) {
  std::optional<ChunkSpan> found;
  walk_chunks(data, size, [&](std::uint32_t chunk_id, ChunkSpan span) {
    if (chunk_id == id) found = span;
    return found.has_value();
  });
  return found;
}

std::optional<std::int64_t> read_integer(const ChunkSpan& chunk, const ChunkField& field) {
  const auto bits = raw_bits(chunk, field);
  if (!bits) return std::nullopt;
  if (!field.is_float) return as_integer(*bits, field);
  const auto f = as_float(*bits, field.length);
  if (!f || !std::isfinite(*f) || std::fabs(*f) >= 9.2e18) return std::nullopt;
  return std::llround(*f);
}

std::optional<double> read_float(const ChunkSpan& chunk, const ChunkField& field) {
  const auto bits = raw_bits(chunk, field);
  if (!bits) return std::nullopt;
  if (field.is_float) return as_float(*bits, field.length);
  return static_cast<double>(as_integer(*bits, field));
}

ResolvedChunkField resolve_chunk_field(ArvGc* gc, const char* feature) {
  ResolvedChunkField r;
  ArvGcNode* node = gc != nullptr ? arv_gc_get_node(gc, feature) : nullptr;
  if (node == nullptr) {
    r.why_not = std::string(feature) + ": no such feature";
    return r;
  }
  // An Integer or Float names the register that holds it by pValue (a few hops at most). Not a
  // Converter or SwissKnife: their pValue is a raw value the formula still has to turn into this.
  for (int hop = 0; hop < 4 && (ARV_IS_GC_INTEGER_NODE(node) || ARV_IS_GC_FLOAT_NODE(node)); ++hop) {
    ArvGcPropertyNode* value = child_property(node, ARV_GC_PROPERTY_NODE_TYPE_P_VALUE);
    node = value != nullptr ? arv_gc_property_node_get_linked_node(value) : nullptr;
    if (node == nullptr) break;
  }
  if (node == nullptr || !(ARV_IS_GC_INT_REG_NODE(node) || ARV_IS_GC_FLOAT_REG_NODE(node))) {
    r.why_not = std::string(feature) + ": not held in an IntReg or FloatReg (a converter, swissknife or masked register)";
    return r;
  }
  ArvGcPropertyNode* port_ref = child_property(node, ARV_GC_PROPERTY_NODE_TYPE_P_PORT);
  ArvGcNode* port = port_ref != nullptr ? arv_gc_property_node_get_linked_node(port_ref) : nullptr;
  ArvGcPropertyNode* id = port != nullptr ? child_property(port, ARV_GC_PROPERTY_NODE_TYPE_CHUNK_ID) : nullptr;
  if (id == nullptr) {
    r.why_not = std::string(feature) + ": its register's port has no ChunkID";
    return r;
  }
  GError* err = nullptr;
  const char* id_text = arv_gc_property_node_get_string(id, &err);
  if (err != nullptr || id_text == nullptr) {
    r.why_not = std::string(feature) + ": ChunkID: " + (err != nullptr ? take_error(err) : "empty");
    return r;
  }
  char* end = nullptr;
  const unsigned long long chunk_id = std::strtoull(id_text, &end, 16);  // hex, as GenICam writes it
  if (end == id_text || *end != '\0' || chunk_id > std::numeric_limits<std::uint32_t>::max()) {
    r.why_not = std::string(feature) + ": ChunkID '" + id_text + "' is not a 32-bit hex number";
    return r;
  }
  ChunkField f;
  f.chunk_id = static_cast<std::uint32_t>(chunk_id);
  f.is_float = ARV_IS_GC_FLOAT_REG_NODE(node);
  f.offset = arv_gc_register_get_address(ARV_GC_REGISTER(node), &err);
  const std::uint64_t length = err == nullptr ? arv_gc_register_get_length(ARV_GC_REGISTER(node), &err) : 0;
  if (err != nullptr) {
    r.why_not = std::string(feature) + ": " + take_error(err);
    return r;
  }
  if (length == 0 || length > 8 || (f.is_float && length != 4 && length != 8)) {
    r.why_not = std::string(feature) + ": a register of " + std::to_string(length) + " bytes";
    return r;
  }
  f.length = static_cast<std::uint32_t>(length);
  ArvGcPropertyNode* order = child_property(node, ARV_GC_PROPERTY_NODE_TYPE_ENDIANNESS);
  f.big_endian = order != nullptr && arv_gc_property_node_get_endianness(order, G_LITTLE_ENDIAN) == G_BIG_ENDIAN;
  ArvGcPropertyNode* sign = child_property(node, ARV_GC_PROPERTY_NODE_TYPE_SIGN);
  f.is_signed = sign != nullptr && arv_gc_property_node_get_sign(sign, ARV_GC_SIGNEDNESS_UNSIGNED) == ARV_GC_SIGNEDNESS_SIGNED;
  r.field = f;
  return r;
}

}  // namespace sensor_rig::camera::detail
