// SPDX-License-Identifier: MIT
// The fields of a control-API request body (and of a fault script's entry,
// which is the same request at a set time): each read checks its type and
// range, and every complaint is an std::invalid_argument that names the key
// and what it may be, in words, never the JSON library's own
// (docs/control-api.md). The API answers it with HTTP 400.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace lbpkit::server::fields {

using nlohmann::json;

bool flag(const json& j, const char* key);
bool flag(const json& j, const char* key, bool otherwise);
// A number from lo to hi; `range` says so in words.
double number(const json& j, const char* key, double lo, double hi, const std::string& range);
// A whole number from 0 to max.
std::uint64_t whole(const json& j, const char* key, std::uint64_t max, const std::string& range);
// A whole number from 0 to limit - 1.
unsigned index(const json& j, const char* key, unsigned limit);
std::string text(const json& j, const char* key);
// Refuses a key not among `known` (a typo such as "delay_ms" must not pass
// as "nothing to change").
void onlyKnown(const json& j, std::initializer_list<std::string_view> known);

template <typename Names>
std::string listed(const Names& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + std::string(n);
  return out.empty() ? "none" : out;
}

}  // namespace lbpkit::server::fields
