#include "sensor_rig/dbw/can/log_decode.hpp"

#include <cstdio>
#include <stdexcept>

#include "sensor_rig/dbw/dbc/codec.hpp"

namespace sensor_rig::dbw::can {

LogDecoder::LogDecoder(const dbc::Database& db, const std::vector<std::string>& selection) : db_(db) {
  auto entry = [this](const dbc::Message* m) -> Selected& {
    for (auto& s : selected_) {
      if (s.message == m) return s;
    }
    selected_.push_back({m, {}});
    return selected_.back();
  };
  if (selection.empty()) {
    for (const auto& m : db.messages) {
      auto& e = entry(&m);
      for (const auto& s : m.signals) e.signals.push_back(&s);
    }
    return;
  }
  for (const auto& item : selection) {
    const auto dot = item.find('.');
    const std::string msg = item.substr(0, dot);
    const std::string sig = dot == std::string::npos ? "*" : item.substr(dot + 1);
    const dbc::Message* m = db.find(msg);
    if (m == nullptr) throw std::invalid_argument("no message '" + msg + "' in the DBC files");
    auto& e = entry(m);
    if (sig == "*") {
      for (const auto& s : m->signals) e.signals.push_back(&s);
      continue;
    }
    const dbc::Signal* s = m->find(sig);
    if (s == nullptr) throw std::invalid_argument("no signal '" + sig + "' in message " + msg);  // NOLINT(performance-inefficient-string-concatenation): an error, once
    e.signals.push_back(s);
  }
}

const LogDecoder::Selected* LogDecoder::find(const Frame& f) const noexcept {
  for (const auto& s : selected_) {
    if (s.message->id == f.id && s.message->extended == f.extended) return &s;
  }
  return nullptr;
}

void LogDecoder::decode(const LogRecord& rec, const std::function<void(const Row&)>& sink, DecodeStats& stats) const {
  ++stats.frames;
  const Frame& f = rec.frame;
  if (f.error || f.rtr) return;
  const Selected* sel = find(f);
  if (sel == nullptr) {
    if (db_.find(f.id, f.extended) == nullptr) ++stats.unknown;
    return;
  }
  ++stats.decoded;
  const auto data = f.payload();
  for (const dbc::Signal* s : sel->signals) {
    if (!dbc::signal_active(*sel->message, *s, data)) continue;
    const auto v = dbc::decode(*s, data);
    if (!v) {
      ++stats.short_frames;
      continue;
    }
    ++stats.rows;
    sink(Row{&rec, sel->message, s, *v});
  }
}

std::string format_id(const Frame& f) {
  char buf[16];
  std::snprintf(buf, sizeof buf, f.extended ? "%08X" : "%03X", f.id);
  return buf;
}

void LogDecoder::write_header(std::ostream& csv) { csv << "t,iface,id,message,signal,value\n"; }

void LogDecoder::write_row(std::ostream& csv, const Row& r) {
  csv << r.record->stamp_text << ',' << r.record->iface << ',' << format_id(r.record->frame) << ','
      << r.message->name << ',' << r.signal->name << ',' << dbc::format_value(*r.signal, r.value) << '\n';
}

DecodeStats LogDecoder::to_csv(std::istream& log, std::ostream& csv) const {
  DecodeStats stats;
  write_header(csv);
  CandumpReader reader(log);
  LogRecord rec;
  const std::function<void(const Row&)> sink = [&csv](const Row& r) { write_row(csv, r); };
  while (reader.next(rec)) decode(rec, sink, stats);
  stats.malformed = reader.malformed();
  return stats;
}

}  // namespace sensor_rig::dbw::can
