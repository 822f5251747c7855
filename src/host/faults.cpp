// SPDX-License-Identifier: MIT
#include "lbpkit/faults.hpp"

#include <array>
#include <string_view>

#include "lbpkit/wire/lbp.hpp"
#include "lbpkit/wire/seven_i77.hpp"
#include "lbpkit/wire/sslbp.hpp"

namespace lbpkit {

namespace {
std::string bits(std::uint8_t v, const std::array<std::string_view, 8>& names) {
  std::string s;
  for (unsigned b = 0; b < 8; ++b) {
    if (!((static_cast<unsigned>(v) >> b) & 1U) || names[b].empty()) continue;
    if (!s.empty()) s += ' ';
    s += names[b];
  }
  return s;
}
}  // namespace

std::string describeLocalFaults(std::uint8_t v) {
  return bits(v, wire::sslbp::cs::kLocalFaultNames);
}
std::string describeStatus(std::uint8_t v) {
  return bits(v, wire::sslbp::cs::kStatusNames);
}
std::string describeRemoteFaults(std::uint8_t v) { return bits(v, wire::i7i77::fault::kNames); }
std::string describeLbpStatus(std::uint8_t v) {
  return bits(v, wire::lbp::status::kNames);
}

std::string describeCs(std::uint32_t cs) {
  std::string s;
  auto add = [&](const std::string& part) {
    if (part.empty()) return;
    if (!s.empty()) s += ' ';
    s += part;
  };
  add(describeLocalFaults(static_cast<std::uint8_t>(cs)));
  add(describeStatus(static_cast<std::uint8_t>(cs >> 8)));
  add(describeRemoteFaults(static_cast<std::uint8_t>(cs >> wire::sslbp::cs::kRemoteByteShift)));
  return s.empty() ? "ok" : s;
}

}  // namespace lbpkit
