// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include <array>
#include <string_view>

#include "lbpkit/wire/crc8.hpp"

namespace {
namespace lbp = lbpkit::wire::lbp;

std::uint8_t crcOf(std::string_view s) {
  return lbp::crc8({reinterpret_cast<const std::uint8_t*>(s.data()), s.size()});
}

TEST(Crc8, MatchesDallasMaximCheckValue) {
  // The standard check value of CRC-8/MAXIM-DOW over "123456789".
  EXPECT_EQ(crcOf("123456789"), 0xA1);
}

TEST(Crc8, TableEntriesTheFirmwareQuotes) {
  // sserialwa.vhd's table comments: crc(1) = 0x5E, crc(2) = 0xBC.
  EXPECT_EQ(lbp::crc8(std::array<std::uint8_t, 1>{0x01}), 0x5E);
  EXPECT_EQ(lbp::crc8(std::array<std::uint8_t, 1>{0x02}), 0xBC);
}

TEST(Crc8, EmptyIsZeroAndAppendingTheCrcGivesZero) {
  EXPECT_EQ(lbp::crc8({}), 0x00);  // the lone CRC of a reply without data
  std::array<std::uint8_t, 4> frame{0xC1, 0x44, 0x12, 0};
  frame[3] = lbp::crc8(std::span(frame).first(3));
  EXPECT_EQ(lbp::crc8(frame), 0x00);
}

}  // namespace
