// The ros2msg schemas (msgs/msg/*.msg) against the IDL the rig really publishes: every registered
// type's schema, parsed back, must describe the same serialized layout as Cyclone's descriptor
// (idlc's ops, from msgs/idl): field count, order, primitive kinds, arrays and sequences, nested
// structs. A field added to an .idl and not to its .msg (or the reverse) fails here.
#include <dds/ddsc/dds_opcodes.h>
#include <gtest/gtest.h>

#include <map>
#include <string>

#include "sensor_rig/dds/type_registry.hpp"
#include "sensor_rig/msgs/ros2msg.hpp"

namespace sensor_rig::dds {
namespace {

std::string prim_from_op(uint32_t type, uint32_t flags) {
  const bool fp = (flags & DDS_OP_FLAG_FP) != 0;
  const bool sgn = (flags & DDS_OP_FLAG_SGN) != 0;
  switch (type) {
    case DDS_OP_VAL_1BY: return sgn ? "i8" : "u8";
    case DDS_OP_VAL_2BY: return sgn ? "i16" : "u16";
    case DDS_OP_VAL_4BY: return fp ? "f32" : sgn ? "i32" : "u32";
    case DDS_OP_VAL_8BY: return fp ? "f64" : sgn ? "i64" : "u64";
    case DDS_OP_VAL_STR: return "str";
    case DDS_OP_VAL_BLN: return "bool";
    default: return "?op" + std::to_string(type);
  }
}

// The layout of the struct whose ops start at ops[i], as "kind kind {nested} seq(kind) arr9(kind) ".
std::string layout_from_ops(const uint32_t* ops, uint32_t i) {
  std::string out;
  while (DDS_OP(ops[i]) != DDS_OP_RTS) {
    const uint32_t op = ops[i];
    if (DDS_OP(op) != DDS_OP_ADR) return out + "?unexpected-op";
    const uint32_t type = DDS_OP_TYPE(op);
    const uint32_t sub = DDS_OP_SUBTYPE(op);
    const uint32_t flags = DDS_OP_FLAGS(op);
    if (type == DDS_OP_VAL_EXT) {
      out += "{" + layout_from_ops(ops, i + static_cast<uint32_t>(DDS_OP_ADR_JSR(ops[i + 2]))) + "} ";
      i += 3;
    } else if (type == DDS_OP_VAL_SEQ || type == DDS_OP_VAL_ARR) {
      const std::string head = type == DDS_OP_VAL_SEQ ? "seq(" : "arr" + std::to_string(ops[i + 2]) + "(";
      if (sub == DDS_OP_VAL_STU) {
        const uint32_t jump_word = type == DDS_OP_VAL_SEQ ? ops[i + 3] : ops[i + 3];
        out += head + "{" + layout_from_ops(ops, i + static_cast<uint32_t>(DDS_OP_ADR_JSR(jump_word))) + "}) ";
        i += DDS_OP_ADR_JMP(jump_word);
      } else {
        out += head + prim_from_op(sub, flags) + ") ";
        i += type == DDS_OP_VAL_SEQ ? 2 : 3;
      }
    } else {
      out += prim_from_op(type, flags) + " ";
      i += 2;
    }
  }
  return out;
}

std::string prim_from_msg(const std::string& t) {
  static const std::map<std::string, std::string> kMap = {
      {"bool", "bool"}, {"byte", "u8"}, {"char", "u8"}, {"uint8", "u8"}, {"int8", "i8"},
      {"uint16", "u16"}, {"int16", "i16"}, {"uint32", "u32"}, {"int32", "i32"}, {"float32", "f32"},
      {"uint64", "u64"}, {"int64", "i64"}, {"float64", "f64"}, {"string", "str"}};
  const auto it = kMap.find(t);
  return it == kMap.end() ? "?msg-" + t : it->second;
}

std::string layout_from_msg(const std::map<std::string, msgs::MsgDefinition>& defs, const std::string& name) {
  const auto it = defs.find(name);
  if (it == defs.end()) return "?missing-" + name;
  std::string out;
  for (const auto& f : it->second.fields) {
    const std::string elem = f.is_primitive() ? prim_from_msg(f.type) : "{" + layout_from_msg(defs, f.type) + "}";
    switch (f.kind) {
      case msgs::MsgField::Kind::kSingle: out += elem + " "; break;
      case msgs::MsgField::Kind::kSequence: out += "seq(" + elem + ") "; break;
      case msgs::MsgField::Kind::kArray: out += "arr" + std::to_string(f.size) + "(" + elem + ") "; break;
    }
  }
  return out;
}

TEST(TypeRegistry, EverySchemaMatchesItsIdlDescriptor) {
  ASSERT_GE(registered_types().size(), 31u);
  for (const auto& t : registered_types()) {
    SCOPED_TRACE(t.dds_name);
    std::map<std::string, msgs::MsgDefinition> defs;
    for (auto& d : msgs::parse_ros2msg_schema(t.schema_name, t.schema)) defs[d.name] = std::move(d);
    const std::string from_msg = layout_from_msg(defs, msgs::short_name(t.schema_name));
    const std::string from_idl = layout_from_ops(t.descriptor->m_ops, 0);
    EXPECT_EQ(from_msg, from_idl);
    EXPECT_EQ(from_idl.find('?'), std::string::npos) << from_idl;
  }
}

TEST(TypeRegistry, KnownLayoutsSpelledOut) {
  // Two layouts written by hand, so the walkers above cannot agree on a wrong reading.
  const auto* pc = find_type("sensor_msgs::msg::dds_::PointCloud2_");
  ASSERT_NE(pc, nullptr);
  EXPECT_EQ(pc->schema_name, "sensor_msgs/msg/PointCloud2");
  EXPECT_EQ(layout_from_ops(pc->descriptor->m_ops, 0),
            "{{i32 u32 } str } u32 u32 seq({str u32 u8 u32 }) bool u32 u32 seq(u8) bool ");
  const auto* fix = find_type_by_schema("sensor_msgs/NavSatFix");
  ASSERT_NE(fix, nullptr);
  EXPECT_EQ(layout_from_ops(fix->descriptor->m_ops, 0), "{{i32 u32 } str } {i8 u16 } f64 f64 f64 arr9(f64) u8 ");
}

TEST(TypeRegistry, SchemaTextIsRosbag2Shaped) {
  const auto* img = find_type_by_schema("sensor_msgs/msg/Image");
  ASSERT_NE(img, nullptr);
  const std::string sep = "\n" + std::string(80, '=') + "\n";
  EXPECT_EQ(img->schema.find("std_msgs/Header header"), img->schema.find("std_msgs/Header"));
  EXPECT_NE(img->schema.find(sep + "MSG: std_msgs/Header\n"), std::string::npos);
  EXPECT_NE(img->schema.find(sep + "MSG: builtin_interfaces/Time\n"), std::string::npos);
  // Each dependency once: PointCloud2 has Header (and its Time) and PointField.
  const auto* pc = find_type_by_schema("sensor_msgs/msg/PointCloud2");
  ASSERT_NE(pc, nullptr);
  std::size_t n = 0;
  for (auto p = pc->schema.find("MSG: "); p != std::string::npos; p = pc->schema.find("MSG: ", p + 1)) ++n;
  EXPECT_EQ(n, 3u);
}

TEST(TypeRegistry, NamesAndUnknownTypes) {
  EXPECT_EQ(schema_name_of("sensor_rig_msgs::msg::dds_::SourceStamps_"), "sensor_rig_msgs/msg/SourceStamps");
  EXPECT_EQ(dds_name_of("diagnostic_msgs/DiagnosticArray"), "diagnostic_msgs::msg::dds_::DiagnosticArray_");
  EXPECT_EQ(schema_name_of("Foo"), "");
  EXPECT_EQ(dds_name_of("no_slash"), "");
  EXPECT_EQ(find_type("geometry_msgs::msg::dds_::Twist_"), nullptr);
  EXPECT_EQ(find_type_by_schema("std_msgs/msg/String"), nullptr);
}

TEST(Ros2Msg, ParserRulesAndErrors) {
  const auto d = msgs::parse_msg("pkg/T", "# c\nuint8 A = 1\nstring<=5 s  # bounded\nHeader h\nOther[] o\nint32[<=3] b\nfloat64[4] a 0\n");
  ASSERT_EQ(d.fields.size(), 5u);
  EXPECT_EQ(d.fields[0].type, "string");
  EXPECT_EQ(d.fields[0].string_bound, 5u);
  EXPECT_EQ(d.fields[1].type, "std_msgs/Header");
  EXPECT_EQ(d.fields[2].type, "pkg/Other");
  EXPECT_EQ(d.fields[2].kind, msgs::MsgField::Kind::kSequence);
  EXPECT_EQ(d.fields[3].size, 3u);
  EXPECT_EQ(d.fields[4].kind, msgs::MsgField::Kind::kArray);
  EXPECT_EQ(d.fields[4].size, 4u);
  EXPECT_THROW(msgs::parse_msg("pkg/T", "uint8\n"), std::invalid_argument);
  EXPECT_THROW(msgs::parse_msg("pkg/T", "uint8[x] a\n"), std::invalid_argument);
  EXPECT_THROW(msgs::parse_ros2msg_schema("pkg/T", "uint8 a\n" + std::string(80, '=') + "\nnot a header\n"),
               std::invalid_argument);
  EXPECT_EQ(msgs::ros2msg_schema("pkg/Nope"), std::nullopt);
}

}  // namespace
}  // namespace sensor_rig::dds
