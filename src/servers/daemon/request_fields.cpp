// SPDX-License-Identifier: MIT
#include "daemon/request_fields.hpp"

#include <fmt/format.h>

#include <limits>
#include <stdexcept>
#include <vector>

namespace lbpkit::server::fields {

bool flag(const json& j, const char* key) {
  if (!j.contains(key)) throw std::invalid_argument(fmt::format("missing \"{}\"", key));
  if (!j.at(key).is_boolean()) throw std::invalid_argument(fmt::format("\"{}\" must be true or false", key));
  return j.at(key).get<bool>();
}

bool flag(const json& j, const char* key, bool otherwise) { return j.contains(key) ? flag(j, key) : otherwise; }

double number(const json& j, const char* key, double lo, double hi, const std::string& range) {
  if (!j.contains(key)) throw std::invalid_argument(fmt::format("missing \"{}\"", key));
  const auto& v = j.at(key);
  const double x = v.is_number() ? v.get<double>() : std::numeric_limits<double>::quiet_NaN();
  if (!(x >= lo && x <= hi)) throw std::invalid_argument(fmt::format("\"{}\" must be a number {}", key, range));
  return x;
}

std::uint64_t whole(const json& j, const char* key, std::uint64_t max, const std::string& range) {
  if (!j.contains(key)) throw std::invalid_argument(fmt::format("missing \"{}\"", key));
  const auto& v = j.at(key);
  // Unsigned as parsed from text; a signed integer (a body built in code)
  // that is not negative is the same number.
  const bool wholeNumber = v.is_number_unsigned() || (v.is_number_integer() && v.get<std::int64_t>() >= 0);
  if (!wholeNumber || v.get<std::uint64_t>() > max)
    throw std::invalid_argument(fmt::format("\"{}\" must be a whole number {}", key, range));
  return v.get<std::uint64_t>();
}

unsigned index(const json& j, const char* key, unsigned limit) {
  return static_cast<unsigned>(whole(j, key, limit - 1U, fmt::format("below {}", limit)));
}

std::string text(const json& j, const char* key) {
  if (!j.contains(key)) throw std::invalid_argument(fmt::format("missing \"{}\"", key));
  if (!j.at(key).is_string()) throw std::invalid_argument(fmt::format("\"{}\" must be a string", key));
  return j.at(key).get<std::string>();
}

void onlyKnown(const json& j, std::initializer_list<std::string_view> known) {
  for (const auto& [key, value] : j.items()) {
    bool ok = false;
    for (auto k : known) ok = ok || k == key;
    if (!ok) {
      std::vector<std::string_view> names(known);
      throw std::invalid_argument(fmt::format("unknown key \"{}\" (known: {})", key, listed(names)));
    }
  }
}

}  // namespace lbpkit::server::fields
