// SPDX-License-Identifier: MIT
#include "config/toml_reader.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <system_error>
#include <vector>
#include "lbpkit/wire/names.hpp"

namespace lbpkit::config {

toml::table parseFile(const std::string& path, std::string_view what) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) throw FileError(fmt::format("{}: no such file", path));
  if (!std::filesystem::is_regular_file(status))
    throw FileError(fmt::format("{}: is not a regular file ({} is expected)", path, what));
  try {
    return toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    throw FileError(
        fmt::format("{}:{}:{}: {}", path, e.source().begin.line, e.source().begin.column, e.description()));
  }
}

void ConfigReader::fail(const toml::node* node, const std::string& key, const std::string& what) const {
  if (node != nullptr && node->source().begin)
    throw FileError(
        fmt::format("{}:{}:{}: {}: {}", path_, node->source().begin.line, node->source().begin.column, key, what));
  throw FileError(fmt::format("{}: {}: {}", path_, key, what));
}

void ConfigReader::onlyKeys(const toml::table& t, const std::string& prefix,
                            std::initializer_list<std::string_view> known) const {
  for (const auto& [k, v] : t) {
    const std::string_view key = k.str();
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    std::string_view best;
    std::size_t bestDistance = 3;  // suggest only near misses
    for (auto candidate : known) {
      const auto d = lbpkit::wire::editDistance(key, candidate);
      if (d < bestDistance) bestDistance = d, best = candidate;
    }
    std::string knownList;
    for (auto candidate : known) knownList += (knownList.empty() ? "" : ", ") + std::string(candidate);
    fail(&v, prefix + std::string(key),
         best.empty() ? fmt::format("unknown key (known here: {})", knownList)
                      : fmt::format("unknown key; did you mean {}?", best));
  }
}

double ConfigReader::numberValue(const toml::node& n, const std::string& name, std::string_view unit) const {
  if (auto f = n.value_exact<double>()) return *f;
  if (auto i = n.value_exact<std::int64_t>()) return static_cast<double>(*i);
  fail(&n, name, fmt::format("expected a number ({}), not {}", unit, typeName(n)));
}

double ConfigReader::number(const toml::table& t, const std::string& prefix, std::string_view key, double fallback,
                            double min, double max, std::string_view unit) const {
  const toml::node* n = t.get(key);
  if (n == nullptr) return fallback;
  const auto name = prefix + std::string(key);
  const double v = numberValue(*n, name, unit);
  if (!std::isfinite(v) || v < min || v > max)
    fail(n, name, fmt::format("{} is out of range: {} to {} {}", v, min, max, unit));
  return v;
}

double ConfigReader::positive(const toml::table& t, const std::string& prefix, std::string_view key,
                              double fallback, double min, double max, std::string_view unit) const {
  return number(t, prefix, key, fallback, min, max, unit);
}

std::pair<double, double> ConfigReader::interval(const toml::table& t, const std::string& prefix,
                                                 std::string_view key, std::pair<double, double> fallback,
                                                 double min, double max, std::string_view unit) const {
  const toml::node* n = t.get(key);
  if (n == nullptr) return fallback;
  const auto name = prefix + std::string(key);
  const auto* a = n->as_array();
  if (a == nullptr || a->size() != 2)
    fail(n, name, fmt::format("expected [low, high] ({}), not {}", unit,
                              a == nullptr ? typeName(*n) : fmt::format("{} values", a->size())));
  double v[2] = {};
  for (std::size_t i = 0; i < 2; ++i) {
    const toml::node& e = *a->get(i);
    const auto element = fmt::format("{}[{}]", name, i);
    v[i] = numberValue(e, element, unit);
    if (!std::isfinite(v[i]) || v[i] < min || v[i] > max)
      fail(&e, element, fmt::format("{} is out of range: {} to {} {}", v[i], min, max, unit));
  }
  if (!(v[0] < v[1])) fail(n, name, fmt::format("[{}, {}]: the low end must be below the high end", v[0], v[1]));
  return {v[0], v[1]};
}

std::int64_t ConfigReader::integer(const toml::table& t, const std::string& prefix, std::string_view key,
                                   std::int64_t fallback, std::int64_t min, std::int64_t max, Radix radix) const {
  const toml::node* n = t.get(key);
  if (n == nullptr) return fallback;
  const auto name = prefix + std::string(key);
  const auto i = n->value_exact<std::int64_t>();
  if (!i) fail(n, name, fmt::format("expected an integer, not {}", typeName(*n)));
  if (*i < min || *i > max) {
    if (radix == Radix::Hex) fail(n, name, fmt::format("0x{:X} is out of range: 0x{:X} to 0x{:X}", *i, min, max));
    fail(n, name, fmt::format("{} is out of range: {} to {}", *i, min, max));
  }
  return *i;
}

bool ConfigReader::boolean(const toml::table& t, const std::string& prefix, std::string_view key,
                           bool fallback) const {
  const toml::node* n = t.get(key);
  if (n == nullptr) return fallback;
  const auto b = n->value_exact<bool>();
  if (!b) fail(n, prefix + std::string(key), fmt::format("expected true or false, not {}", typeName(*n)));
  return *b;
}

std::string ConfigReader::text(const toml::table& t, const std::string& prefix, std::string_view key,
                               std::string fallback, std::initializer_list<std::string_view> allowed) const {
  const toml::node* n = t.get(key);
  if (n == nullptr) return fallback;
  const auto s = n->value_exact<std::string>();
  const auto name = prefix + std::string(key);
  std::string list;
  for (auto a : allowed) list += (list.empty() ? "\"" : ", \"") + std::string(a) + "\"";
  if (!s) fail(n, name, fmt::format("expected a string ({}), not {}", list, typeName(*n)));
  if (std::find(allowed.begin(), allowed.end(), *s) == allowed.end())
    fail(n, name, fmt::format("\"{}\" is not one of {}", *s, list));
  return *s;
}

std::string ConfigReader::name(const toml::table& t, const std::string& prefix, std::string_view key,
                               std::string fallback) const {
  const toml::node* n = t.get(key);
  if (n == nullptr) return fallback;
  const auto s = n->value_exact<std::string>();
  const auto full = prefix + std::string(key);
  if (!s) fail(n, full, fmt::format("expected a string (a name), not {}", typeName(*n)));
  const bool ok = !s->empty() && s->size() <= 40 && std::all_of(s->begin(), s->end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
  if (!ok) fail(n, full, fmt::format("\"{}\" is not a name: 1 to 40 letters, digits, '_' or '-'", *s));
  return *s;
}

const toml::node& ConfigReader::required(const toml::table& t, const std::string& prefix, std::string_view key) const {
  const toml::node* n = t.get(key);
  if (n == nullptr) fail(&t, prefix + std::string(key), "missing (this key is required)");
  return *n;
}

const toml::table* ConfigReader::table(const toml::table& t, const std::string& prefix, std::string_view key) const {
  const toml::node* n = t.get(key);
  if (n == nullptr) return nullptr;
  const auto* table = n->as_table();
  if (table == nullptr)
    fail(n, prefix + std::string(key), fmt::format("expected a table ([{}]), not {}", key, typeName(*n)));
  return table;
}

const toml::array* ConfigReader::tables(const toml::table& t, const std::string& prefix, std::string_view key) const {
  const toml::node* n = t.get(key);
  if (n == nullptr) return nullptr;
  const auto* array = n->as_array();
  if (array == nullptr)
    fail(n, prefix + std::string(key), fmt::format("expected an array of tables ([[{}]]), not {}", key, typeName(*n)));
  return array;
}

const toml::table& ConfigReader::element(const toml::array& a, const std::string& name, std::size_t i) const {
  const auto* t = a.get(i)->as_table();
  if (t == nullptr) fail(a.get(i), fmt::format("{}[{}]", name, i), fmt::format("expected a table, not {}", typeName(*a.get(i))));
  return *t;
}

std::string ConfigReader::where(const toml::node* node) {
  if (node == nullptr || !node->source().begin) return "?";
  return fmt::format("{}:{}", node->source().begin.line, node->source().begin.column);
}

std::string ConfigReader::typeName(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a number";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::table: return "a table";
    case toml::node_type::array: return "an array";
    default: return "a date or time";
  }
}

}  // namespace lbpkit::config
