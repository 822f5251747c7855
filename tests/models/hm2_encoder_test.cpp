// SPDX-License-Identifier: MIT
// HostMot2 QCount (plain encoder): the muxed counters' logic at its own
// registers, sampling every filter-rate tick (docs/hostmot2-modules.md#qcount-plain-encoder).
#include <gtest/gtest.h>

#include <cstdint>

#include "hostmot2/encoder.hpp"
#include "support/hm2_module_expect.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

namespace {

using hm2::Encoder;
using hm2::MuxedEncoder;
using hm2::SimTime;

constexpr std::uint32_t kClock = 100'000'000;

TEST(Encoder, DescriptorAndRegistersAreQCounts) {
  Encoder e(Encoder::kDefaultBase, 4, kClock);
  testing_hm2::expectDescriptor(e.descriptor(), {4, 2, hm2::kClockLow, 4, 0x3000, 5, 0, 0x03});
  EXPECT_EQ(e.name(), "QCount");
  EXPECT_TRUE(e.decodes(0x3000));
  EXPECT_TRUE(e.decodes(0x3400));
  EXPECT_FALSE(e.decodes(0x3404));
  EXPECT_FALSE(e.decodes(0x3500)) << "the muxed counters' block";
  // qcounterate.vhd's power-up divisor: round(100 MHz / 16 MHz) - 2.
  EXPECT_EQ(e.read(0x3400, SimTime{}), 4U);
  EXPECT_EQ(e.samplePeriod(), SimTime{60});
  // LinuxCNC's 25 MHz: 100 / 25 - 2.
  EXPECT_EQ(e.write(0x3400, 2, SimTime{}), hm2::WriteResult::Accepted);
  EXPECT_EQ(e.samplePeriod(), SimTime{40});
  e.write(0x3104, MuxedEncoder::kFilter, SimTime{});
  EXPECT_EQ(e.read(0x3104, SimTime{}) & 0xFFF8U, MuxedEncoder::kFilter);
  EXPECT_EQ(e.read(0x3100, SimTime{}) & 0xFFF8U, 0U);
  // The muxed counters are unchanged by the sharing.
  MuxedEncoder m(6, kClock);
  EXPECT_EQ(m.descriptor().gtag, 0x0C);
  EXPECT_EQ(m.descriptor().baseAddress, 0x3500);
  EXPECT_EQ(m.name(), "MuxedQCount");
  EXPECT_EQ(m.read(MuxedEncoder::kRate, SimTime{}), 11U);
}

TEST(Encoder, CountsAtItsOwnAddresses) {
  Encoder e(Encoder::kDefaultBase, 2, kClock);
  e.setVelocity(1, -40'000.0, SimTime{});  // counts per second
  const SimTime t{10'000'000};             // 10 ms: -400 counts
  EXPECT_EQ(static_cast<std::int16_t>(e.read(0x3004, t) & 0xFFFFU), -400);
  EXPECT_EQ(e.read(0x3000, t) & 0xFFFFU, 0U);
  e.write(0x3004, 0, t);  // any write clears
  EXPECT_EQ(e.read(0x3004, t) & 0xFFFFU, 0U);
  // At the power-up sampling (every 60 ns) the filter wants a state to last
  // three samples, 180 ns: at 2 MHz (500 ns a state) every count is made,
  // at 6 MHz (167 ns) counts are lost, as on the card.
  Encoder fast(Encoder::kDefaultBase, 1, kClock);
  fast.setVelocity(0, 2e6, SimTime{});
  EXPECT_EQ(fast.read(0x3000, SimTime{1'000'000}) & 0xFFFFU, 2000U);
  Encoder tooFast(Encoder::kDefaultBase, 1, kClock);
  tooFast.setVelocity(0, 6e6, SimTime{});
  EXPECT_LT(tooFast.read(0x3000, SimTime{1'000'000}) & 0xFFFFU, 6000U - 100U);
}

}  // namespace
