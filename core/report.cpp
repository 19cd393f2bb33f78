#include "core/report.h"

#include <algorithm>

namespace sm {

Warning& Warnings::find_or_add(std::string_view kind, std::string_view message) {
  for (auto& w : list_) {
    if (w.kind == kind) return w;
  }
  list_.push_back(Warning{std::string(kind), std::string(message), 0, {}});
  return list_.back();
}

void Warnings::add(std::string_view kind, std::string_view message, std::string_view where) {
  Warning& w = find_or_add(kind, message);
  ++w.count;
  if (!where.empty() && w.examples.size() < max_kept_examples) w.examples.emplace_back(where);
}

void Warnings::add_count(std::string_view kind, std::string_view message, std::size_t n) {
  if (n == 0) return;
  find_or_add(kind, message).count += n;
}

void Warnings::merge(const Warnings& other) {
  for (const auto& o : other.list_) {
    Warning& w = find_or_add(o.kind, o.message);
    w.count += o.count;
    for (const auto& e : o.examples) {
      if (w.examples.size() >= max_kept_examples) break;
      w.examples.push_back(e);
    }
  }
}

std::size_t Warnings::count(std::string_view kind) const {
  for (const auto& w : list_) {
    if (w.kind == kind) return w.count;
  }
  return 0;
}

std::size_t Warnings::total() const {
  std::size_t n = 0;
  for (const auto& w : list_) n += w.count;
  return n;
}

std::string Warnings::to_string() const {
  std::string out;
  for (const auto& w : list_) {
    out += w.message;
    out += " (" + std::to_string(w.count) + "x";
    for (std::size_t i = 0; i < std::min(w.examples.size(), max_examples); ++i) {
      out += i == 0 ? "; e.g. " : ", ";
      out += w.examples[i];
    }
    out += ")\n";
  }
  return out;
}

void Timings::add(std::string_view name, double seconds) {
  for (auto& e : entries) {
    if (e.name == name) {
      e.seconds += seconds;
      return;
    }
  }
  entries.push_back(Entry{std::string(name), seconds});
}

double Timings::get(std::string_view name) const {
  for (const auto& e : entries) {
    if (e.name == name) return e.seconds;
  }
  return 0;
}

double Timings::total() const {
  double t = 0;
  for (const auto& e : entries) t += e.seconds;
  return t;
}

}  // namespace sm
