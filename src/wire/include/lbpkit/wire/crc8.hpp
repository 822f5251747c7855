// SPDX-License-Identifier: MIT
// LBP CRC-8: the Dallas/Maxim 1-Wire CRC (x^8 + x^5 + x^4 + 1), reflected
// form 0x8C, initial value 0 (docs/protocol-facts.md#crc-8; manual: LBP, CRC).
#pragma once

#include <array>
#include <cstdint>
#include <span>

namespace lbpkit::wire::lbp {

namespace detail {
constexpr std::uint8_t crc8Step(std::uint8_t crc) {
  for (int i = 0; i < 8; ++i)
    crc = (crc & 1U) ? static_cast<std::uint8_t>((crc >> 1) ^ 0x8CU) : static_cast<std::uint8_t>(crc >> 1);
  return crc;
}
constexpr std::array<std::uint8_t, 256> makeCrc8Table() {
  std::array<std::uint8_t, 256> t{};
  for (unsigned i = 0; i < 256; ++i) t[i] = crc8Step(static_cast<std::uint8_t>(i));
  return t;
}
inline constexpr std::array<std::uint8_t, 256> kCrc8Table = makeCrc8Table();
}  // namespace detail

class Crc8 {
 public:
  void add(std::uint8_t byte) { value_ = detail::kCrc8Table[value_ ^ byte]; }
  void add(std::span<const std::uint8_t> bytes) {
    for (auto b : bytes) add(b);
  }
  [[nodiscard]] std::uint8_t value() const { return value_; }
  void reset() { value_ = 0; }

 private:
  std::uint8_t value_ = 0;
};

inline std::uint8_t crc8(std::span<const std::uint8_t> bytes) {
  Crc8 c;
  c.add(bytes);
  return c.value();
}

}  // namespace lbpkit::wire::lbp
