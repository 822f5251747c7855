// SPDX-License-Identifier: MIT
// The encoders' HM2DPLL timer register (LinuxCNC encoder.c: base + 5
// strides, (timer-number << 12) | 0x8000; hostmot2.9 encoder.timer-number):
// present only with a DPLL, and latching the counts and the timestamp
// counter on the selected source's rising edge (docs/hostmot2-modules.md#qcount-plain-encoder).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include "hostmot2/card.hpp"
#include "hostmot2/dpll.hpp"
#include "hostmot2/encoder.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

namespace {

using hm2::Dpll;
using hm2::Encoder;
using hm2::MuxedEncoder;
using hm2::SimTime;

constexpr std::uint32_t kClock = 100'000'000;  // 10 ns ticks
SimTime ticks(std::uint64_t n) { return SimTime{static_cast<std::int64_t>(n * 10)}; }

// A 1 kHz reference (prescale 24) and timer 1 at -100 us, as LinuxCNC sets them.
void runAsLinuxCncDoes(Dpll& dpll) {
  dpll.write(0x7200, (24U << 24) | 0x400000U, SimTime{});
  dpll.write(0x7000, 1055531162U, SimTime{});
  dpll.write(0x7400, 6553, SimTime{});  // (u32)(100 / 1000 * 65536)
}

TEST(EncoderDpllTimer, TheRegisterIsThereOnlyWithADpll) {
  MuxedEncoder plain(6, kClock);
  EXPECT_FALSE(plain.decodes(0x3A00));
  EXPECT_EQ(plain.write(0x3A00, 0x8000, SimTime{}), hm2::WriteResult::Unmapped);
  Dpll dpll(Dpll::kKind.base, 1, kClock);
  MuxedEncoder m(6, kClock);
  m.attachDpll(&dpll);
  EXPECT_TRUE(m.decodes(0x3A00));
  EXPECT_FALSE(m.decodes(0x3A04));  // one register for every counter
  // encoder.c's probe: it writes 0 and makes timer-number when 0 reads back.
  EXPECT_EQ(m.write(0x3A00, 0, SimTime{}), hm2::WriteResult::Accepted);
  EXPECT_EQ(m.read(0x3A00, SimTime{}), 0U);
  m.write(0x3A00, (3U << 12) | MuxedEncoder::kTimerEnable | 0x0FFFU, SimTime{});
  EXPECT_EQ(m.read(0x3A00, SimTime{}), (3U << 12) | MuxedEncoder::kTimerEnable);
  m.reset();
  EXPECT_EQ(m.read(0x3A00, SimTime{}), 0U);
  // The plain QCount's is at its own base + 5 strides.
  Encoder q(Encoder::kDefaultBase, 2, kClock);
  EXPECT_FALSE(q.decodes(0x3500));
  q.attachDpll(&dpll);
  EXPECT_TRUE(q.decodes(0x3500));
  // On the card: the 7I96S's "d" firmware has the DPLL, the 7I92's none.
  hm2::HostMot2Card::Options o;
  o.card = hm2::cards::find("7I96S");
  hm2::HostMot2Card card(o);
  card.write32(0x3A00, MuxedEncoder::kTimerEnable | (1U << 12), SimTime{});
  EXPECT_EQ(card.read32(0x3A00, SimTime{1000}), MuxedEncoder::kTimerEnable | (1U << 12));
  EXPECT_EQ(card.unmappedWrites() + card.unmappedReads(), 0U);
  hm2::HostMot2Card plainCard;
  plainCard.write32(0x3A00, 0, SimTime{});
  EXPECT_EQ(plainCard.unmappedWrites(), 1U);
}

TEST(EncoderDpllTimer, CountsAndTimestampAreTheTimersRisingEdges) {
  Dpll dpll(Dpll::kKind.base, 1, kClock);
  runAsLinuxCncDoes(dpll);
  MuxedEncoder e(2, kClock);
  e.attachDpll(&dpll);
  constexpr double kVelocity = 100'000.0;  // counts/s: 10 us a count
  e.setVelocity(1, kVelocity, SimTime{});
  e.write(0x3A00, MuxedEncoder::kTimerEnable | (1U << 12), SimTime{});
  for (const std::uint64_t t : {250'000ULL, 333'333ULL, 1'000'000ULL, 2'500'000ULL}) {
    SCOPED_TRACE(t);
    const std::uint32_t count = e.read(MuxedEncoder::kCount + 4, ticks(t));
    const auto edge = dpll.lastRisingEdge(1, ticks(t));
    ASSERT_TRUE(edge.has_value());
    EXPECT_LT(t - *edge, 100'000U + 24U);  // the timer fires 100 us before the reference
    // The count at the edge (to within the filter's delay), not at the read.
    EXPECT_NEAR(count & 0xFFFFU, kVelocity * static_cast<double>(*edge) / kClock, 1.0);
    EXPECT_EQ(e.read(MuxedEncoder::kTimestamp, ticks(t)), (*edge / 2) & 0xFFFFU);  // TSDiv 0: every 2 ticks
    // A read at the same moment gives the same latch.
    EXPECT_EQ(e.read(MuxedEncoder::kCount + 4, ticks(t)), count);
  }
  // -1 (0): no latching, the registers read live.
  e.write(0x3A00, 0, ticks(2'500'000));
  const std::uint32_t live = e.read(MuxedEncoder::kCount + 4, ticks(2'500'001)) & 0xFFFFU;
  EXPECT_NEAR(live, kVelocity * 0.025, 1.0);
  EXPECT_EQ(e.read(MuxedEncoder::kTimestamp, ticks(2'500'002)), (2'500'002U / 2) & 0xFFFFU);
}

}  // namespace
