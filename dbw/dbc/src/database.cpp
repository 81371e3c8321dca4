#include "sensor_rig/dbw/dbc/database.hpp"

namespace sensor_rig::dbw::dbc {

const Signal* Message::find(std::string_view signal) const noexcept {
  for (const auto& s : signals) {
    if (s.name == signal) return &s;
  }
  return nullptr;
}

const Signal* Message::multiplexor() const noexcept {
  for (const auto& s : signals) {
    if (s.mux == MuxRole::kMultiplexor) return &s;
  }
  return nullptr;
}

const Message* Database::find(std::uint32_t id, bool extended) const noexcept {
  for (const auto& m : messages) {
    if (m.id == id && m.extended == extended) return &m;
  }
  return nullptr;
}

Message* Database::find_mutable(std::uint32_t id, bool extended) noexcept {
  for (auto& m : messages) {
    if (m.id == id && m.extended == extended) return &m;
  }
  return nullptr;
}

const Message* Database::find(std::string_view name) const noexcept {
  for (const auto& m : messages) {
    if (m.name == name) return &m;
  }
  return nullptr;
}

namespace {
std::optional<AttributeValue> lookup(const Attributes& own, const Database& db, std::string_view name) {
  if (const auto it = own.find(name); it != own.end()) return it->second;
  if (const auto d = db.attribute_definitions.find(name); d != db.attribute_definitions.end()) {
    return d->second.default_value;
  }
  return std::nullopt;
}
}  // namespace

std::optional<AttributeValue> Database::attribute(const Message& m, std::string_view name) const {
  return lookup(m.attributes, *this, name);
}

std::optional<AttributeValue> Database::attribute(const Signal& s, std::string_view name) const {
  return lookup(s.attributes, *this, name);
}

std::optional<std::int64_t> Database::cycle_time_ms(const Message& m) const {
  const auto v = attribute(m, "GenMsgCycleTime");
  if (!v) return std::nullopt;
  const auto n = attribute_number(*v);
  if (!n) return std::nullopt;
  return static_cast<std::int64_t>(*n);
}

std::size_t Database::signal_count() const noexcept {
  std::size_t n = 0;
  for (const auto& m : messages) n += m.signals.size();
  return n;
}

std::optional<double> attribute_number(const AttributeValue& v) noexcept {
  if (const auto* i = std::get_if<std::int64_t>(&v)) return static_cast<double>(*i);
  if (const auto* d = std::get_if<double>(&v)) return *d;
  return std::nullopt;
}

}  // namespace sensor_rig::dbw::dbc
