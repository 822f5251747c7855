// SPDX-License-Identifier: MIT
// The 7I96S's TB3 modules as LinuxCNC's inm.c, ssr.c and outm.c drive them
// (docs/hostmot2-modules.md#inm, #ssr, #outm): InM's debounce filter and MPG
// counters over the card's I/O pins, SSR's drive rate and switches, OutM's
// outputs, and where the 7I96S's firmware puts them.
#include <gtest/gtest.h>

#include <cstdint>

#include "support/hm2_module_expect.hpp"
#include "hostmot2/card.hpp"
#include "hostmot2/inm.hpp"
#include "hostmot2/ioport.hpp"
#include "hostmot2/outm.hpp"
#include "hostmot2/ssr.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

namespace {

using namespace std::chrono_literals;
using hm2::InM;
using hm2::OutM;
using hm2::SimTime;
using hm2::Ssr;

constexpr std::uint32_t kClockLow = 100'000'000;
constexpr unsigned kInputs = 11;  // the 7I96S's IN0..IN10

std::uint16_t inmReg(unsigned r) { return static_cast<std::uint16_t>(InM::kKind.base + r * hm2::kRegisterStride); }

// inm.c hm2_inm_write with its defaults: 20 kHz per input, 5 and 500 scans,
// the invert bit.
std::uint32_t linuxCncControl(unsigned inputs = kInputs) {
  const double scanrate = inputs * 20000.0;
  const auto divisor = static_cast<std::uint32_t>(static_cast<int>(kClockLow / (4 * scanrate)) - 1);
  return (1U << 5) + (divisor << 6) + (5U << 16) + (500U << 22);
}

// An InM over the first 11 pins of a one-port IOPort, as the 7I96S wires it.
struct Tb3 {
  hm2::IoPort io{1, 17};
  InM inm{InM::kKind.base, 1, kInputs, kClockLow};
  SimTime now{};
  Tb3() {
    for (unsigned n = 0; n < kInputs; ++n) inm.connect(&io, 0, n, 0, n);
  }
  // The world energizes input n (its pin goes low) at the present moment.
  void energize(unsigned n, bool on) { io.setInput(0, n, !on); }
  void wait(SimTime t) {
    now += t;
    inm.advance(now);
  }
  std::uint32_t read(unsigned r) { return inm.read(inmReg(r), now); }
};

TEST(InM, DescriptorAndControlAreWhatInmCReads) {
  Tb3 t;
  testing_hm2::expectDescriptor(t.inm.descriptor(), {0x23, 0, hm2::kClockLow, 1, 0x8500, 5, 0, 0x1F});
  // inm.c: scan width = (control & 0x1F) + 1, read before anything is written.
  EXPECT_EQ(t.read(InM::kControl) & 0x1FU, kInputs - 1);
  EXPECT_EQ(t.inm.write(inmReg(InM::kControl), 0xFFFFFFFFU, t.now), hm2::WriteResult::Accepted);
  EXPECT_EQ(t.read(InM::kControl), 0xFFFFFFE0U | (kInputs - 1));  // MaxBit stays read only
  t.inm.write(inmReg(InM::kFilter), 0xFFFFFFFFU, t.now);
  EXPECT_EQ(t.read(InM::kFilter), (1U << kInputs) - 1);
  EXPECT_EQ(t.inm.write(inmReg(InM::kFiltered), 1, t.now), hm2::WriteResult::ReadOnly);
  EXPECT_EQ(t.inm.write(inmReg(InM::kRaw), 1, t.now), hm2::WriteResult::ReadOnly);
  EXPECT_FALSE(t.inm.decodes(0x8504));  // one instance
  EXPECT_FALSE(t.inm.decodes(0x8A00));  // five registers
  EXPECT_EQ(t.inm.write(0x8504, 1, t.now), hm2::WriteResult::Unmapped);
}

TEST(InM, TheInvertBitMakesAnEnergizedInputReadOne) {
  Tb3 t;
  // Power-up: no invert, idle pins high.
  EXPECT_EQ(t.read(InM::kRaw), (1U << kInputs) - 1);
  t.inm.write(inmReg(InM::kControl), linuxCncControl(), t.now);
  EXPECT_EQ(t.read(InM::kRaw), 0U);
  t.energize(3, true);
  EXPECT_EQ(t.read(InM::kRaw), 1U << 3);
  EXPECT_TRUE(t.inm.rawInput(0, 3));
}

TEST(InM, AnInputTakesItsNewLevelAfterItsShortOrLongFilterTime) {
  Tb3 t;
  t.inm.write(inmReg(InM::kControl), linuxCncControl(), t.now);
  t.wait(30ms);  // every input settles on "off" (the long time is 24.9 ms)
  ASSERT_EQ(t.read(InM::kFiltered), 0U);
  // divisor 112: a scan of 11 inputs is 4 * 113 * 11 = 4972 ticks, 49.72 us;
  // 5 scans 248.6 us, 500 scans 24.86 ms.
  EXPECT_EQ(t.inm.filterTime(0, 0), SimTime{248'600});
  t.inm.write(inmReg(InM::kFilter), 1U << 7, t.now);  // input 7 slow
  EXPECT_EQ(t.inm.filterTime(0, 7), SimTime{24'860'000});
  t.energize(0, true);
  t.energize(7, true);
  t.wait(248us);
  EXPECT_FALSE(t.inm.input(0, 0));
  EXPECT_EQ(t.read(InM::kRaw), 1U << 0 | 1U << 7);
  t.wait(1us);
  EXPECT_TRUE(t.inm.input(0, 0));
  EXPECT_FALSE(t.inm.input(0, 7));
  t.wait(24'860us - 249us - 1us);
  EXPECT_FALSE(t.inm.input(0, 7));
  t.wait(1us);
  EXPECT_TRUE(t.inm.input(0, 7));
  EXPECT_EQ(t.read(InM::kFiltered), 1U << 0 | 1U << 7);
  // A pulse shorter than the filter time never shows.
  t.energize(2, true);
  t.wait(200us);
  t.energize(2, false);
  t.wait(1ms);
  EXPECT_FALSE(t.inm.input(0, 2));
  // Power-up: registers 0, every filtered input what its pin shows.
  t.inm.reset();
  EXPECT_EQ(t.read(InM::kControl), kInputs - 1);
  EXPECT_EQ(t.read(InM::kFiltered), (1U << kInputs) - 1 - (1U << 0 | 1U << 7));
}

// hostmot2.9: "The quadrature inputs for MPG encoders 0 through 3 are
// inm/inmux pins 0 through 7"; inm.c reads byte k as counter k and writes
// bit 0 of byte k for 4X.
TEST(InM, MpgCountersCountTheFilteredQuadratureOfInputPairs) {
  Tb3 t;
  t.inm.write(inmReg(InM::kControl), linuxCncControl(), t.now);
  t.wait(30ms);
  // A quadrature cycle forward on MPG 1 (inputs 2 = A, 3 = B), each state
  // held past the filter time.
  const bool forward[4][2] = {{true, false}, {true, true}, {false, true}, {false, false}};
  auto cycle = [&](bool reverse) {
    for (unsigned s = 0; s < 4; ++s) {
      const auto& ab = forward[reverse ? (2 - s + 4) % 4 : s];
      t.energize(2, ab[0]);
      t.energize(3, ab[1]);
      t.wait(300us);
    }
  };
  cycle(false);
  EXPECT_EQ(t.inm.mpgCount(0, 1), 1U);  // 1X at power-up: one count per cycle
  t.inm.write(inmReg(InM::kMpg), 1U << 8, t.now);  // MPG 1 in 4X
  cycle(false);
  EXPECT_EQ(t.inm.mpgCount(0, 1), 5U);
  EXPECT_EQ((t.read(InM::kMpg) >> 8) & 0xFFU, 5U);
  cycle(true);
  cycle(true);
  EXPECT_EQ(t.inm.mpgCount(0, 1), static_cast<std::uint8_t>(5 - 8));  // 8 bits, wrapping
  EXPECT_EQ(t.inm.mpgCount(0, 0), 0U);
  // Both inputs changing at once is no step either way.
  t.inm.write(inmReg(InM::kMpg), 1U << 16, t.now);
  t.energize(4, true);
  t.energize(5, true);
  t.wait(300us);
  EXPECT_EQ(t.inm.mpgCount(0, 2), 0U);
}

std::uint16_t ssrReg(unsigned r) { return static_cast<std::uint16_t>(Ssr::kKind.base + r * hm2::kRegisterStride); }

TEST(Ssr, ASwitchClosesOnlyWhileTheDriveRuns) {
  Ssr s(Ssr::kKind.base, 1, kClockLow);
  const SimTime t{};
  testing_hm2::expectDescriptor(s.descriptor(), {0xC3, 0, hm2::kClockLow, 1, 0x7D00, 2, 0, 0x3});
  // ssr.c loads 0 into both, then data from out-NN XOR invert-NN.
  s.write(ssrReg(Ssr::kData), 0b0101, t);
  EXPECT_FALSE(s.closed(0, 0));  // no drive yet
  // The default 1 MHz: ClockLow / (2 * rate) - 2 = 48, with the enable bit.
  s.write(ssrReg(Ssr::kRate), 48U | Ssr::kEnable, t);
  EXPECT_DOUBLE_EQ(s.driveFrequency(0), 1e6);
  EXPECT_TRUE(s.closed(0, 0));
  EXPECT_FALSE(s.closed(0, 1));
  EXPECT_TRUE(s.closed(0, 2));
  EXPECT_EQ(s.read(ssrReg(Ssr::kData), t), 0b0101U);
  s.write(ssrReg(Ssr::kRate), 0xFFFFFFFFU, t);
  EXPECT_EQ(s.read(ssrReg(Ssr::kRate), t), 0x1FFFU);  // 12 divisor bits and the enable
  EXPECT_NEAR(s.driveFrequency(0), 1e8 / 0x1001 / 2, 1e-6);  // ssr.c: 0xFFF gives 12.2 kHz
  s.write(ssrReg(Ssr::kRate), 0, t);  // the rate pin at 0 disables the instance
  EXPECT_FALSE(s.closed(0, 0));
  EXPECT_DOUBLE_EQ(s.driveFrequency(0), 0.0);
  EXPECT_FALSE(s.decodes(0x7D04));
  EXPECT_FALSE(s.decodes(0x7F00));
  s.write(ssrReg(Ssr::kRate), 48U | Ssr::kEnable, t);
  s.reset();
  EXPECT_FALSE(s.driving(0));
  EXPECT_EQ(s.read(ssrReg(Ssr::kData), t), 0U);
}

TEST(OutM, DataBitsAreTheOutputs) {
  OutM o(OutM::kKind.base, 1);
  const SimTime t{};
  testing_hm2::expectDescriptor(o.descriptor(), {0x2D, 0, hm2::kClockLow, 1, 0xB000, 1, 0, 0x1});
  EXPECT_EQ(o.write(0xB000, 1U << 5, t), hm2::WriteResult::Accepted);
  EXPECT_TRUE(o.output(0, 5));
  EXPECT_FALSE(o.output(0, 4));
  EXPECT_EQ(o.read(0xB000, t), 1U << 5);
  EXPECT_FALSE(o.decodes(0xB004));
  EXPECT_FALSE(o.decodes(0xB100));
  EXPECT_EQ(o.write(0xB004, 1, t), hm2::WriteResult::Unmapped);
  o.reset();
  EXPECT_FALSE(o.output(0, 5));
}

// The 7I96S's firmware: TB3's IN0..IN10 are InM inputs 0..10 on IO0..10,
// OUT0..OUT3 SSR outputs 0..3 on IO11..14, OUT4 and OUT5 OutM outputs 4 and
// 5 on IO15 and IO16 (pncconf's 7i96s_d); the InM reads the card's pins.
TEST(Tb3, The7I96SCarriesInmSsrAndOutmOnTb3) {
  hm2::HostMot2Card::Options options;
  options.card = hm2::cards::find("7I96S");
  hm2::HostMot2Card card(options);
  ASSERT_NE(card.module<hm2::InM>(), nullptr);
  ASSERT_NE(card.module<hm2::Ssr>(), nullptr);
  ASSERT_NE(card.module<hm2::OutM>(), nullptr);
  EXPECT_EQ(card.module(InM::kKind.tag), card.module<hm2::InM>());
  EXPECT_EQ(card.module(Ssr::kKind.tag), card.module<hm2::Ssr>());
  EXPECT_EQ(card.module(OutM::kKind.tag), card.module<hm2::OutM>());
  EXPECT_EQ(card.module<hm2::InM>()->inputs(), kInputs);
  const auto& words = card.idromWords();
  const unsigned pins = words[lbpkit::wire::hm2::idrom::kOffsetToPinsField / 4] / 4;
  auto fn = [&](unsigned io) { return words[pins + io] & 0x00FFFFFFU; };
  EXPECT_EQ(fn(0), 0x002301U);   // InM input 0
  EXPECT_EQ(fn(10), 0x00230BU);  // InM input 10
  EXPECT_EQ(fn(11), 0x00C381U);  // SSR out 0
  EXPECT_EQ(fn(14), 0x00C384U);  // SSR out 3
  EXPECT_EQ(fn(15), 0x002D85U);  // OutM out 4
  EXPECT_EQ(fn(16), 0x002D86U);  // OutM out 5
  EXPECT_EQ(fn(17), 0x000581U);  // TB1 as on the other firmwares: StepGen 0 Step
  // The other firmwares have none of them.
  EXPECT_EQ(hm2::HostMot2Card().module<hm2::InM>(), nullptr);
  // An input energized at the terminals reaches the filtered data register.
  SimTime now{1ms};
  card.write32(0x8500, linuxCncControl(), now);
  card.part<hm2::IoPort>().setInput(0, 9, false);
  now += 1ms;
  EXPECT_EQ(card.read32(0x8700, now), 1U << 9);
  EXPECT_EQ(card.read32(0x8800, now), 1U << 9);
  card.write32(0x7E00, 48U | Ssr::kEnable, now);
  card.write32(0x7D00, 1U << 2, now);
  card.write32(0xB000, 1U << 4, now);
  EXPECT_TRUE(card.module<hm2::Ssr>()->closed(0, 2));
  EXPECT_TRUE(card.module<hm2::OutM>()->output(0, 4));
  EXPECT_EQ(card.unmappedReads() + card.unmappedWrites(), 0U);
  // Power off and on: the switches open, the outputs off.
  card.powerCycle(now + 1ms);
  EXPECT_FALSE(card.module<hm2::Ssr>()->closed(0, 2));
  EXPECT_FALSE(card.module<hm2::OutM>()->output(0, 4));
}

}  // namespace
