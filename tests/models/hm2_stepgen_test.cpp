// SPDX-License-Identifier: MIT
// HostMot2 StepGen as LinuxCNC's stepgen.c drives it: registers, exact step
// counts in simulated time, pulse and direction timing, the DPLL timer latch
// (docs/hostmot2-modules.md#stepgen).
#include <gtest/gtest.h>

#include <cstdint>
#include <random>

#include "hostmot2/dpll.hpp"
#include "hostmot2/stepgen.hpp"
#include "support/hm2_module_expect.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

namespace {

using hm2::SimTime;
using hm2::StepGen;

constexpr std::uint32_t kClock = 100'000'000;  // 10 ns ticks
constexpr std::uint16_t kBase = StepGen::kKind.base;

SimTime ticks(std::uint64_t n) { return SimTime{static_cast<std::int64_t>(n * 10)}; }
std::uint16_t reg(unsigned r, unsigned instance = 0) {
  return static_cast<std::uint16_t>(kBase + r * hm2::kRegisterStride + instance * 4);
}

// Step timing as LinuxCNC writes it (ns * ClockLow / 1e9).
void setTimings(StepGen& s, unsigned n, std::uint32_t width, std::uint32_t idle, std::uint32_t setup,
                std::uint32_t hold) {
  s.write(reg(StepGen::kPulseWidth, n), width, SimTime{});
  s.write(reg(StepGen::kPulseIdle, n), idle, SimTime{});
  s.write(reg(StepGen::kDirSetup, n), setup, SimTime{});
  s.write(reg(StepGen::kDirHold, n), hold, SimTime{});
}

TEST(StepGen, DescriptorIsWhatLinuxCncAccepts) {
  StepGen s(kBase, 5, kClock, 2);
  testing_hm2::expectDescriptor(s.descriptor(), {5, 2, hm2::kClockLow, 5, 0x2000, 10, 0, 0x1FF});
}

TEST(StepGen, RegistersRoundTripWithTheirWidths) {
  StepGen s(kBase, 3, kClock, 0x42);
  const SimTime t{};
  struct Case {
    unsigned r;
    std::uint32_t written, read;
  };
  for (const Case c : {Case{StepGen::kRate, 0x89ABCDEFU, 0x89ABCDEFU}, Case{StepGen::kMode, 0xFFU, 0x07U},
                       Case{StepGen::kDirSetup, 0xFFFFU, 0x3FFFU}, Case{StepGen::kDirHold, 0x1234U, 0x1234U},
                       Case{StepGen::kPulseWidth, 0x4001U, 0x0001U}, Case{StepGen::kPulseIdle, 77U, 77U},
                       Case{StepGen::kTableLength, 0x13U, 0x3U}}) {
    EXPECT_EQ(s.write(reg(c.r, 2), c.written, t), hm2::WriteResult::Accepted) << c.r;
    EXPECT_EQ(s.read(reg(c.r, 2), t), c.read) << c.r;
    EXPECT_EQ(s.read(reg(c.r, 1), t), 0U) << "instance 1 untouched, register " << c.r;
  }
  // The accumulator loads bits 47..16 and reads them back.
  s.write(reg(StepGen::kAccumulator, 0), 0x00050000U, t);
  EXPECT_EQ(s.read(reg(StepGen::kAccumulator, 0), t), 0x00050000U);
  // Single registers: only at offset 0; no fourth instance.
  EXPECT_TRUE(s.decodes(0x2900));
  EXPECT_FALSE(s.decodes(0x2904));
  EXPECT_TRUE(s.decodes(0x2A00));
  EXPECT_FALSE(s.decodes(reg(StepGen::kRate, 3)));
  EXPECT_EQ(s.write(reg(StepGen::kRate, 3), 1, t), hm2::WriteResult::Unmapped);
  s.write(0x2900, 0xFFFFFFFFU, t);
  EXPECT_EQ(s.read(0x2900, t), 0xFFFFFFFFU);
  s.write(0x2A00, (2U << 12) | StepGen::kTimerEnable | 0x0FFFU, t);
  EXPECT_EQ(s.read(0x2A00, t), (2U << 12) | StepGen::kTimerEnable);
  // Version 2 has no swap bit.
  StepGen v2(kBase, 1, kClock, 2);
  v2.write(reg(StepGen::kMode), 0x7, t);
  EXPECT_EQ(v2.read(reg(StepGen::kMode), t), 0x3U);
}

TEST(StepGen, StepCountAfterSimulatedTimeIsExact) {
  // Rates LinuxCNC might write; timings short enough never to hold a step.
  for (const std::int32_t rate : {123456789, -98765432, 4294968, 1, -1}) {
    StepGen s(kBase, 1, kClock);
    setTimings(s, 0, 10, 10, 300, 300);  // a step may follow the last 24 ticks on
    s.write(reg(StepGen::kRate), static_cast<std::uint32_t>(rate), SimTime{});
    const std::uint64_t n = 100'000;  // 1 ms
    // Every ClockLow tick adds the rate to the 48-bit accumulator; a step is
    // a carry into (borrow from) bit 32.
    // Going down, the direction output changes at the first tick and the
    // add that would step waits out the 300-tick setup time (and its tick).
    const std::uint64_t adds = rate < 0 ? n - 301 : n;
    const std::int64_t total = static_cast<std::int64_t>(rate) * static_cast<std::int64_t>(adds);
    const std::int64_t expected = total >= 0 ? total >> 32 : -((-total + (std::int64_t{1} << 32) - 1) >> 32);
    EXPECT_EQ(s.steps(0, ticks(n)), expected) << rate;
    EXPECT_EQ(s.read(reg(StepGen::kAccumulator), ticks(n)), static_cast<std::uint32_t>(static_cast<std::uint64_t>(total) >> 16))
        << rate;
  }
}

TEST(StepGen, CountsDoNotDependOnHowTimeIsSplit) {
  // Free-running and timing-limited rates, both directions, a direction
  // change half way: one long advance and many short ones agree exactly.
  std::mt19937 rng(17);
  for (const std::int32_t rate : {0x7FFFFFFF, 123456789, -2000000000, 4294968}) {
    StepGen a(kBase, 1, kClock), b(kBase, 1, kClock);
    for (StepGen* s : {&a, &b}) {
      setTimings(*s, 0, 100, 100, 50, 70);
      s->write(reg(StepGen::kRate), static_cast<std::uint32_t>(rate), SimTime{});
    }
    std::uint64_t t = 0;
    while (t < 50'000) {
      t += 1 + rng() % 3;  // mostly one step per advance: the step-by-step path
      (void)b.steps(0, ticks(t));
    }
    EXPECT_EQ(a.steps(0, ticks(t)), b.steps(0, ticks(t))) << rate;
    EXPECT_EQ(a.read(reg(StepGen::kAccumulator), ticks(t)), b.read(reg(StepGen::kAccumulator), ticks(t)));
    for (StepGen* s : {&a, &b}) s->write(reg(StepGen::kRate), static_cast<std::uint32_t>(-rate), ticks(t));
    const std::uint64_t end = t + 60'000;
    while (t < end) {
      t += 1 + rng() % 3;
      (void)b.pins(0, ticks(t));
    }
    EXPECT_EQ(a.steps(0, ticks(t)), b.steps(0, ticks(t))) << rate;
    EXPECT_EQ(a.read(reg(StepGen::kAccumulator), ticks(t)), b.read(reg(StepGen::kAccumulator), ticks(t)));
    EXPECT_EQ(a.pins(0, ticks(t)).dir, rate > 0);
  }
}

TEST(StepGen, TimingsLimitTheStepRate) {
  // Asking for a step every 2 ticks with 1 us pulses and 1 us idle: steps
  // come one pulse + idle (+ the firmware's 4 ticks of pipeline) apart.
  StepGen s(kBase, 1, kClock);
  setTimings(s, 0, 100, 100, 0, 0);
  s.write(reg(StepGen::kRate), 0x7FFFFFFFU, SimTime{});
  const std::uint64_t gap = 100 + 100 + 4;
  // The first add that carries is the third (2^32 / (2^31 - 1) rounded up).
  const std::uint64_t n = 1'000'000;
  EXPECT_EQ(s.steps(0, ticks(n)), static_cast<std::int64_t>((n - 3) / gap + 1));
  EXPECT_NEAR(s.stepRate(0), kClock / 2.0, 1.0);  // what was asked for
}

// The tick of the next rising edge of the step output after tick t (t ends there).
std::uint64_t nextRise(StepGen& s, std::uint64_t& t) {
  bool prev = s.pins(0, ticks(t)).step;
  for (;;) {
    const bool level = s.pins(0, ticks(++t)).step;
    if (level && !prev) return t;
    prev = level;
  }
}

TEST(StepGen, StepPulseAndDirectionFollowTheTimings) {
  constexpr std::uint32_t kWidth = 10, kIdle = 10, kSetup = 300, kHold = 500;
  StepGen s(kBase, 1, kClock);
  setTimings(s, 0, kWidth, kIdle, kSetup, kHold);
  s.write(reg(StepGen::kRate), 4294968U, SimTime{});  // about a step every 1000 ticks
  std::uint64_t t = 0;
  const std::uint64_t rise = nextRise(s, t);
  while (s.pins(0, ticks(t)).step) ++t;
  EXPECT_EQ(t - rise, kWidth + 1U) << "pulse high for width + 1 ticks";
  EXPECT_FALSE(s.pins(0, ticks(t)).dir);
  // Reverse just after a step: the direction pin waits for the hold time
  // after it, and the first step back for the setup time after that.
  const std::int64_t before = s.steps(0, ticks(t));
  const std::uint64_t last = nextRise(s, t);
  EXPECT_EQ(s.steps(0, ticks(t)), before + 1);
  t += 50;
  s.write(reg(StepGen::kRate), static_cast<std::uint32_t>(-4294968), ticks(t));
  std::uint64_t dirAt = 0;
  while (dirAt == 0)
    if (s.pins(0, ticks(++t)).dir) dirAt = t;
  const std::uint64_t backAt = nextRise(s, t);
  EXPECT_GE(dirAt - last, kHold) << "direction changed inside the hold time";
  EXPECT_LE(dirAt - last, kHold + 2U);
  EXPECT_GE(backAt - dirAt, kSetup) << "stepped inside the setup time";
  EXPECT_LE(backAt - dirAt, kSetup + 3U);
  EXPECT_EQ(s.steps(0, ticks(backAt)), before) << "one step forward, one back";
}

TEST(StepGen, StepDirModesAndSwap) {
  StepGen s(kBase, 1, kClock, 0x42);
  setTimings(s, 0, 50, 50, 0, 0);
  s.write(reg(StepGen::kRate), static_cast<std::uint32_t>(-4294968), SimTime{});
  // Step/dir swapped: the dir level on output 0.
  s.write(reg(StepGen::kMode), StepGen::kSwapStepDir, SimTime{});
  const auto p = s.pins(0, ticks(5000));
  EXPECT_TRUE(p.step) << "output 0 carries dir (down)";
  // Up/down: a down step pulses output 1 only.
  s.write(reg(StepGen::kMode), 1, ticks(5000));
  bool up = false, down = false;
  for (std::uint64_t t = 5001; t < 8000; ++t) {
    const auto q = s.pins(0, ticks(t));
    up |= (q.outputs & 1U) != 0;
    down |= (q.outputs & 2U) != 0;
  }
  EXPECT_FALSE(up);
  EXPECT_TRUE(down);
}

TEST(StepGen, QuadratureAndTableOutputs) {
  StepGen s(kBase, 1, kClock);
  const SimTime t{};
  // Quadrature: outputs from accumulator bits 31..30 (register bits 15..14), Gray coded.
  s.write(reg(StepGen::kMode), 2, t);
  const std::uint32_t gray[] = {0, 1, 3, 2};
  for (std::uint32_t q = 0; q < 4; ++q) {
    s.write(reg(StepGen::kAccumulator), q << 14, t);
    EXPECT_EQ(s.pins(0, t).outputs, gray[q]) << q;
  }
  // Table: stepgen.c writes the last entry first, then the length - 1;
  // each step moves to the next entry.
  StepGen g(kBase, 1, kClock);
  setTimings(g, 0, 20, 20, 0, 0);
  const std::uint32_t table[] = {0x5, 0x6, 0xA, 0x9};
  for (int j = 3; j >= 0; --j) g.write(reg(StepGen::kTableData), table[j], t);
  g.write(reg(StepGen::kTableLength), 3, t);
  g.write(reg(StepGen::kMode), 3, t);
  EXPECT_EQ(g.pins(0, t).outputs, table[0]);
  g.write(reg(StepGen::kRate), 4294968U, t);
  for (std::uint64_t tick = 500; tick < 10'000; tick += 1000) {
    const auto steps = g.steps(0, ticks(tick));
    EXPECT_EQ(g.pins(0, ticks(tick)).outputs, table[steps % 4]) << steps;
  }
  EXPECT_EQ(g.steps(0, ticks(10'000)), 10);
}

TEST(StepGen, DpllTimerLatchesTheAccumulator) {
  hm2::Dpll dpll(hm2::Dpll::kKind.base, 1, kClock);
  StepGen s(kBase, 1, kClock);
  s.attachDpll(&dpll);
  // A 1 kHz reference (prescale 24) and timer 1 at -100 us, as LinuxCNC sets them.
  dpll.write(0x7200, (24U << 24) | 0x400000U, SimTime{});
  dpll.write(0x7000, 1055531162U, SimTime{});
  dpll.write(0x7400, 6553, SimTime{});  // (u32)(100 / 1000 * 65536)
  const std::uint32_t rate = 123456789;
  s.write(reg(StepGen::kRate), rate, SimTime{});
  s.write(0x2A00, StepGen::kTimerEnable | (1U << 12), SimTime{});
  for (const std::uint64_t t : {250'000ULL, 333'333ULL, 1'000'000ULL}) {
    const std::uint32_t v = s.read(reg(StepGen::kAccumulator), ticks(t));
    const auto edge = dpll.lastRisingEdge(1, ticks(t));
    ASSERT_TRUE(edge.has_value());
    EXPECT_LT(t - *edge, 100'000U + 24U);
    EXPECT_EQ(v, static_cast<std::uint32_t>((std::uint64_t{rate} * *edge) >> 16)) << t;
  }
  // Disabled: the accumulator reads live.
  s.write(0x2A00, 0, ticks(1'000'000));
  EXPECT_EQ(s.read(reg(StepGen::kAccumulator), ticks(1'000'001)),
            static_cast<std::uint32_t>((std::uint64_t{rate} * 1'000'001) >> 16));
}

TEST(StepGen, ResetStopsMotionButKeepsTheMachinesStepCount) {
  StepGen s(kBase, 1, kClock);
  setTimings(s, 0, 20, 20, 0, 0);
  s.write(reg(StepGen::kRate), 4294968U, SimTime{});
  const std::int64_t made = s.steps(0, ticks(100'000));
  EXPECT_EQ(made, 100);
  s.reset();
  EXPECT_EQ(s.read(reg(StepGen::kRate), ticks(100'000)), 0U);
  EXPECT_EQ(s.steps(0, ticks(200'000)), made);
  EXPECT_EQ(s.read(reg(StepGen::kAccumulator), ticks(200'000)), 0U);
}

}  // namespace
