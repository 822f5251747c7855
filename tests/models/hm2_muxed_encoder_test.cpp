// SPDX-License-Identifier: MIT
// HostMot2 MuxedQCount (hostmot2/muxed_encoder.hpp) brought up to a time far
// ahead in one step, as the card thread does after a stall: an index every
// count costs no more than counting, and the counts and latches are those
// of walking every count.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdint>

#include "hostmot2/muxed_encoder.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// An index every count (1 count per revolution) at 2 MHz with latch on
// index: the model walked every index, one by one. Computed now, with the
// same results.
TEST(MuxedEncoderCatchUp, AnIndexEveryCountCostsNoMoreThanOne) {
  constexpr std::uint32_t kClock = 100'000'000;
  for (const std::uint32_t mode : {hm2::MuxedEncoder::kLatchOnIndex, hm2::MuxedEncoder::kLatchOnIndex | hm2::MuxedEncoder::kClearOnIndex}) {
    for (const std::uint32_t cpr : {1U, 7U}) {
      hm2::MuxedEncoder enc(6, kClock);
      // LinuxCNC's mux rate (8.33 MHz ticks): 2 MHz is within what it counts
      // exactly (the power-up rate, 7.69 MHz, stops at 1.92 MHz).
      ASSERT_EQ(enc.write(hm2::MuxedEncoder::kRate, 10, hm2::SimTime{0}), hm2::WriteResult::Accepted);
      for (unsigned n = 0; n < 6; ++n) {
        ASSERT_EQ(enc.write(static_cast<std::uint16_t>(hm2::MuxedEncoder::kControl + 4 * n), mode, hm2::SimTime{0}),
                  hm2::WriteResult::Accepted);
        enc.setIndexPeriod(n, cpr);
        enc.setVelocity(n, n % 2 ? -2e6 : 2e6, hm2::SimTime{0});
      }
      const auto start = Clock::now();
      const hm2::SimTime end{100'000'000'000LL + 123'456};  // 100 s and a bit: 2e8 counts each
      enc.advance(end);
      ASSERT_LT(Clock::now() - start, 100ms) << "mode " << mode << " cpr " << cpr;
      for (unsigned n = 0; n < 6; ++n) {
        // The position in counts, and so the count and the last index.
        const auto p = static_cast<std::int64_t>(std::floor(enc.signal(n).position));
        const auto ccr = enc.read(static_cast<std::uint16_t>(hm2::MuxedEncoder::kControl + 4 * n), end);
        const auto latched = static_cast<std::uint16_t>(ccr >> 16);
        const auto c = static_cast<std::int64_t>(cpr);
        const std::int64_t lastIndex = p >= 0 ? (p / c) * c : -((-p) / c) * c;  // the index crossed last
        if (mode & hm2::MuxedEncoder::kClearOnIndex) {
          // Cleared at every index: latched one revolution, counting since the last.
          EXPECT_EQ(latched, static_cast<std::uint16_t>(p >= 0 ? c : -c)) << n;
          EXPECT_EQ(enc.count(n), static_cast<std::uint16_t>(p - lastIndex)) << n << " p " << p;
        } else {
          // Counting on; latched the count at the last index.
          EXPECT_EQ(enc.count(n), static_cast<std::uint16_t>(p)) << n;
          EXPECT_EQ(latched, static_cast<std::uint16_t>(lastIndex)) << n << " p " << p;
        }
      }
    }
  }
}

}  // namespace
