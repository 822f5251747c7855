// SPDX-License-Identifier: MIT
// HostMot2 HM2DPLL as LinuxCNC's dpll.c drives it: registers, the timer
// period, lock to the host's sync reads, the timer offsets
// (docs/hostmot2-modules.md#dpll).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include "hostmot2/dpll.hpp"
#include "support/hm2_module_expect.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

namespace {

using hm2::Dpll;
using hm2::SimTime;

constexpr std::uint32_t kClock = 100'000'000;
constexpr std::uint16_t kBase = Dpll::kKind.base;
constexpr std::uint16_t kBaseRate = 0x7000, kPhase = 0x7100, kControl0 = 0x7200, kControl1 = 0x7300,
                        kTimers12 = 0x7400, kTimers34 = 0x7500, kSync = 0x7600;

SimTime ticks(std::uint64_t n) { return SimTime{static_cast<std::int64_t>(n * 10)}; }

// What dpll.c writes for a servo period (ns) once it has read ddsize, with
// timer 1 at timer1Us (LinuxCNC's default time-const 2000, plimit 0x400000).
void configureLikeLinuxCnc(Dpll& d, double periodNs, double timer1Us, SimTime t) {
  const auto ddsize = d.read(kControl1, t) & 0xFFU;
  const double baseHz = 1e9 / periodNs;
  const auto prescale = static_cast<std::uint32_t>(0x40000000LL * static_cast<double>(kClock) /
                                                   (std::ldexp(1.0, static_cast<int>(ddsize)) * baseHz));
  const auto base = static_cast<std::uint32_t>(baseHz * std::ldexp(1.0, static_cast<int>(ddsize)) * prescale / kClock);
  d.write(kBaseRate, base, t);
  d.write(kControl0, prescale << 24 | 0x400000U, t);
  d.write(kControl1, 2000U << 16, t);
  const double periodUs = periodNs / 1000.0;
  const auto timer = static_cast<std::uint32_t>(static_cast<std::int32_t>(-timer1Us / periodUs * 65536.0));
  d.write(kTimers12, timer & 0xFFFFU, t);
}

TEST(Dpll, DescriptorIsWhatLinuxCncAccepts) {
  Dpll d(kBase, 1, kClock);
  // Tag 0x1A: HM2_GTAG_HM2DPLL (26).
  testing_hm2::expectDescriptor(d.descriptor(), {0x1A, 0, hm2::kClockLow, 1, 0x7000, 7, 0, 0});
  EXPECT_TRUE(d.decodes(kSync));
  EXPECT_FALSE(d.decodes(0x7700));
  EXPECT_FALSE(d.decodes(0x7004));
}

TEST(Dpll, RegistersRoundTrip) {
  Dpll d(kBase, 1, kClock);
  const SimTime t{};
  d.write(kBaseRate, 0x12345678U, t);
  EXPECT_EQ(d.read(kBaseRate, t), 0x12345678U);
  d.write(kControl0, 0x18400000U, t);
  EXPECT_EQ(d.read(kControl0, t) >> 24, 0x18U);        // prescale
  EXPECT_EQ(d.read(kControl0, t) & 0xFFFFFFU, 0U);      // no correction yet
  d.write(kControl1, 0x07D0ABCDU, t);
  EXPECT_EQ(d.read(kControl1, t), 0x07D00000U | 42U);   // filter prescale, ddsize 42
  d.write(kTimers12, 0x11112222U, t);
  d.write(kTimers34, 0x33334444U, t);
  EXPECT_EQ(d.read(kTimers12, t), 0x11112222U);
  EXPECT_EQ(d.read(kTimers34, t), 0x33334444U);
  d.write(kPhase, 0xDEADBEEFU, t);
  EXPECT_EQ(d.read(kPhase, t), 0xDEADBEEFU);
  EXPECT_EQ(d.read(kSync, t), 0xDEADBEEFU);
  EXPECT_EQ(d.state().phaseError, 0xDEADBEEFU);
  EXPECT_EQ(d.write(0x7700, 1, t), hm2::WriteResult::Unmapped);
}

TEST(Dpll, ReferencePeriodIsTheBaseRate) {
  Dpll d(kBase, 1, kClock);
  configureLikeLinuxCnc(d, 1e6, -100.0, SimTime{});
  // Free-running (no sync reads): the reference rises every 2^42 / rate
  // adds of one per prescale ticks: 1 ms.
  const auto s = d.state();
  EXPECT_EQ(s.prescale, 24);
  const double period = std::ldexp(1.0, 42) / s.baseRate * s.prescale;
  EXPECT_NEAR(period, 100'000.0, 1.0);
  const auto e1 = d.lastRisingEdge(0, ticks(250'000));
  const auto e2 = d.lastRisingEdge(0, ticks(350'000));
  ASSERT_TRUE(e1 && e2);
  EXPECT_NEAR(static_cast<double>(*e2 - *e1), period, 24.0);
  // Timer 1 at -100 us: 100 us (10 000 ticks) before each reference edge.
  const auto t1 = d.lastRisingEdge(1, ticks(*e2 - 1));
  ASSERT_TRUE(t1);
  EXPECT_NEAR(static_cast<double>(*e2 - *t1), 10'000.0, 24.0);
  // No base rate, no edges.
  Dpll idle(kBase, 1, kClock);
  EXPECT_FALSE(idle.lastRisingEdge(0, ticks(1'000'000)).has_value());
}

// A LinuxCNC servo thread: each period it reads the sync register (its
// phase error) and, for the first 100 cycles, zeroes the phase.
double runServoThread(Dpll& d, double periodNs, std::uint64_t offsetNs, int cycles) {
  double errorUs = 0;
  for (int k = 0; k < cycles; ++k) {
    const SimTime t{static_cast<std::int64_t>(offsetNs + static_cast<std::uint64_t>(k * periodNs))};
    const auto sync = static_cast<std::int32_t>(d.read(kSync, t));
    errorUs = sync * (periodNs / 4294967296000.0);
    if (k < 100) d.write(kPhase, 0, t + SimTime{20'000});
  }
  return errorUs;
}

TEST(Dpll, LocksToTheServoThread) {
  // The phase error LinuxCNC shows (dpll.phase-error-us) settles near 0 at
  // the nominal period; with the PC's clock off from the card's it settles
  // where the loop's correction makes up the difference (the loop has no
  // pure integrator: about 6 us at 100 ppm at 1 kHz), and stays there.
  struct Case {
    double period, maxErrorUs;
  };
  for (const Case c : {Case{1e6, 0.5}, Case{1.0001e6, 8.0}, Case{0.99995e6, 4.0}}) {
    Dpll d(kBase, 1, kClock);
    configureLikeLinuxCnc(d, 1e6, -100.0, SimTime{});
    const double before = runServoThread(d, c.period, 123'457, 2900);
    Dpll again(kBase, 1, kClock);
    configureLikeLinuxCnc(again, 1e6, -100.0, SimTime{});
    const double err = runServoThread(again, c.period, 123'457, 3000);
    EXPECT_LT(std::abs(err), c.maxErrorUs) << c.period;
    EXPECT_NEAR(err, before, 0.5) << "locked, not drifting: " << c.period;
    // Timer 1 fires 100 us (10 000 ticks) before the servo read, give or
    // take the phase error.
    const SimTime read{static_cast<std::int64_t>(123'457 + 2999 * c.period)};
    const auto t1 = again.lastRisingEdge(1, read);
    ASSERT_TRUE(t1);
    const double lead = static_cast<double>(hm2::clockTicks(read, kClock)) - static_cast<double>(*t1);
    EXPECT_NEAR(lead, 10'000.0 + err * 100.0, 100.0) << c.period;
  }
}

}  // namespace
