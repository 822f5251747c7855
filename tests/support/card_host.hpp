// SPDX-License-Identifier: MIT
// Test helper: a host driving the virtual card's registers in simulated time.
#pragma once

#include <gtest/gtest.h>

#include "hostmot2/card.hpp"

namespace testing_hm2 {

using lbpkit::model::hm2::SimTime;

struct CardHost {
  lbpkit::model::hm2::HostMot2Card& card;
  SimTime now{0};
  SimTime accessTime = SimTime{1000};  // each register access takes 1 us

  std::uint32_t read(std::uint16_t a) {
    now += accessTime;
    return card.read32(a, now);
  }
  void write(std::uint16_t a, std::uint32_t v) {
    now += accessTime;
    card.write32(a, v, now);
  }
  void wait(SimTime t) {
    now += t;
    card.advance(now);
  }
  // Polls COMMAND until it reads 0; returns how long that took, or a
  // negative time when `limit` passed first.
  SimTime waitCommand(SimTime limit = std::chrono::seconds(10)) {
    const SimTime start = now;
    while (read(lbpkit::model::hm2::Sslbp::kCommand) != 0) {
      if (now - start > limit) return SimTime{-1};
    }
    return now - start;
  }
  std::uint8_t command(std::uint32_t cmd) {
    write(lbpkit::model::hm2::Sslbp::kCommand, cmd);
    EXPECT_GE(waitCommand().count(), 0) << "command " << std::hex << cmd << " never completed";
    return static_cast<std::uint8_t>(read(lbpkit::model::hm2::Sslbp::kData));
  }
  static std::uint16_t cs(unsigned ch) { return static_cast<std::uint16_t>(lbpkit::model::hm2::Sslbp::kCs + 4 * ch); }
  static std::uint16_t iface(unsigned n, unsigned ch) {
    return static_cast<std::uint16_t>(lbpkit::model::hm2::Sslbp::kInterface0 + n * 0x100 + 4 * ch);
  }
  // SETUP MODE OPERATION: one remote command through CS and DOIT.
  std::uint64_t remote(unsigned ch, std::uint8_t lbpCommand, std::uint16_t address, std::uint64_t data = 0) {
    write(iface(0, ch), static_cast<std::uint32_t>(data));
    write(iface(1, ch), static_cast<std::uint32_t>(data >> 32));
    write(cs(ch), (static_cast<std::uint32_t>(lbpCommand) << 24) | address);
    const auto failed = command(lbpkit::model::hm2::command::kDoit | (1U << ch));
    EXPECT_EQ(failed, 0) << "remote command " << std::hex << int(lbpCommand) << " at " << address;
    return read(iface(0, ch)) | (static_cast<std::uint64_t>(read(iface(1, ch))) << 32);
  }
};

}  // namespace testing_hm2
