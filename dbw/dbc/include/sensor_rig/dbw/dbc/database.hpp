#pragma once
// The DBC data model: nodes, messages, signals, value tables, attributes, comments.
// Plain values; built by dbc::parse(), read by the codec. Ids are stored without the DBC
// extended-id flag (bit 31); `extended` says which id space a message lives in.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace sensor_rig::dbw::dbc {

enum class ByteOrder : std::uint8_t { kIntel, kMotorola };  // DBC @1 (little endian), @0 (big endian)
enum class ValueType : std::uint8_t { kInteger, kFloat32, kFloat64 };  // SIG_VALTYPE_ 0/1/2
enum class MuxRole : std::uint8_t { kNone, kMultiplexor, kMultiplexed };

using AttributeValue = std::variant<std::int64_t, double, std::string>;
using Attributes = std::map<std::string, AttributeValue, std::less<>>;

struct Signal {
  std::string name;
  std::uint16_t start_bit = 0;  // as written in the DBC (Motorola: MSB in sawtooth numbering)
  std::uint16_t length = 1;     // bits, 1..64
  ByteOrder order = ByteOrder::kIntel;
  bool is_signed = false;
  ValueType value_type = ValueType::kInteger;
  double factor = 1.0;
  double offset = 0.0;
  double minimum = 0.0;
  double maximum = 0.0;
  int decimals = 0;  // decimals needed to print physical values exactly (from factor/offset text)
  std::string unit;
  std::vector<std::string> receivers;
  MuxRole mux = MuxRole::kNone;
  std::uint64_t mux_value = 0;  // for multiplexed signals: the multiplexor value selecting it
  std::map<std::int64_t, std::string> value_names;  // VAL_
  std::string comment;
  Attributes attributes;
  int line = 0;  // where it was defined
};

struct Message {
  std::uint32_t id = 0;  // 11 or 29 bits
  bool extended = false;
  std::string name;
  std::uint8_t size = 0;  // bytes, 0..64
  std::string sender;
  std::vector<Signal> signals;
  std::string comment;
  Attributes attributes;
  std::vector<std::string> transmitters;  // BO_TX_BU_
  int line = 0;

  [[nodiscard]] const Signal* find(std::string_view signal) const noexcept;
  [[nodiscard]] const Signal* multiplexor() const noexcept;
};

enum class AttributeKind : std::uint8_t { kInteger, kHex, kFloating, kString, kEnumeration };
enum class AttributeScope : std::uint8_t { kNetwork, kNode, kMessage, kSignal, kEnvVar };

struct AttributeDefinition {
  std::string name;
  AttributeScope scope = AttributeScope::kNetwork;
  AttributeKind kind = AttributeKind::kInteger;
  double minimum = 0.0;
  double maximum = 0.0;
  std::vector<std::string> enum_values;
  std::optional<AttributeValue> default_value;  // BA_DEF_DEF_
};

struct Database {
  std::string version;
  std::vector<std::string> nodes;
  std::map<std::string, std::string, std::less<>> node_comments;
  std::vector<Message> messages;
  std::map<std::string, std::map<std::int64_t, std::string>, std::less<>> value_tables;  // VAL_TABLE_
  std::map<std::string, AttributeDefinition, std::less<>> attribute_definitions;
  Attributes attributes;  // network scope
  std::string comment;    // network comment(s)

  [[nodiscard]] const Message* find(std::uint32_t id, bool extended) const noexcept;
  [[nodiscard]] const Message* find(std::string_view name) const noexcept;
  [[nodiscard]] Message* find_mutable(std::uint32_t id, bool extended) noexcept;
  // Attribute of a message or signal, falling back to the BA_DEF_DEF_ default.
  [[nodiscard]] std::optional<AttributeValue> attribute(const Message& m, std::string_view name) const;
  [[nodiscard]] std::optional<AttributeValue> attribute(const Signal& s, std::string_view name) const;
  // GenMsgCycleTime in ms (0 or absent: not periodic).
  [[nodiscard]] std::optional<std::int64_t> cycle_time_ms(const Message& m) const;
  [[nodiscard]] std::size_t signal_count() const noexcept;
};

// Numeric value of an attribute (int or float), nullopt for strings.
[[nodiscard]] std::optional<double> attribute_number(const AttributeValue& v) noexcept;

}  // namespace sensor_rig::dbw::dbc
