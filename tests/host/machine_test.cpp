// SPDX-License-Identifier: MIT
// The plant behind the 7I77: a machine on the in-process card,
// driven through the host library at 1 kHz as LinuxCNC would drive it.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "lbpkit/encoders.hpp"
#include "machine/machine.hpp"
#include "support/running_card.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace machine = lbpkit::model::machine;

namespace {

using namespace std::chrono_literals;
using machine::Machine;

constexpr double kCountsPerMm = 1600.0;  // mill: 2000 lines, 5 mm/rev
constexpr double kOneCount = 1.0 / kCountsPerMm;

// The in-process card, the host's view of it, and a machine behind it; one
// cycle() is a 1 kHz servo period: outputs out, inputs and counts in, the
// plant run to the next period, simulated time to the next period.
struct Rig {
  testing_host::RunningCard rc;
  lbpkit::MuxedEncoders enc;
  Machine m;
  std::array<lbpkit::ElementRef, 6> aout;
  lbpkit::ElementRef ena, spin, output, input;
  std::array<std::int64_t, 6> countsAtStart{};

  explicit Rig(machine::MachineDescription d = machine::mill())
      : enc(rc.t, rc.info), m(std::move(d), rc.t.card(), hm2::SimTime{rc.t.now()}) {
    enc.initialize();
    for (unsigned i = 0; i < 6; ++i) aout[i] = rc.ss.find(1, "analogout" + std::to_string(i));
    ena = rc.ss.find(1, "analogena");
    spin = rc.ss.find(1, "spinena");
    output = rc.ss.find(0, "output");
    input = rc.ss.find(0, "input");
    cycle();
    for (unsigned i = 0; i < 6; ++i) countsAtStart[i] = enc.counts(i);
  }
  void cycle() {
    auto& t = rc.t;
    const auto start = t.now();
    rc.ss.queueOutputs();
    enc.queue();
    t.flush();
    ASSERT_TRUE(rc.ss.collectInputs().ok);
    ASSERT_TRUE(enc.update());
    m.advance(hm2::SimTime{start + 1ms});
    t.sleep(start + 1ms - t.now());
  }
  // Counted position of an axis of the mill (its encoder n), in mm.
  [[nodiscard]] double counted(unsigned n, double initial) const {
    return initial + static_cast<double>(enc.counts(n) - countsAtStart[n]) / kCountsPerMm;
  }
  [[nodiscard]] bool in(unsigned i) const { return rc.ss.bit(input, i); }
  void setVolts(unsigned ch, double v) { rc.ss.set(aout[ch], v); }
  void setEnable(bool on) { rc.ss.setRaw(ena, on ? 1 : 0); }
  void setOutputs(std::uint16_t bits) { rc.ss.setRaw(output, bits); }
};

double clampVolts(double v) { return std::clamp(v, -10.0, 10.0); }

// A P position loop per axis on the counted positions, as a servo thread
// closes it; the true positions settle within one encoder count.
TEST(Machine, PLoopSettlesEveryAxisWithinOneCount) {
  Rig r;
  const std::array<double, 3> initial{200.0, 150.0, -75.0};
  const std::array<double, 3> target{250.0, 120.5, -20.25};
  constexpr double kp = 5.0;  // V per mm: 125 /s with 25 mm/s per volt
  r.setEnable(true);
  r.setOutputs(1U << 2);  // Z brake released
  for (int i = 0; i < 3000; ++i) {
    for (unsigned a = 0; a < 3; ++a) r.setVolts(a, clampVolts(kp * (target[a] - r.counted(a, initial[a]))));
    r.cycle();
  }
  for (unsigned a = 0; a < 3; ++a) {
    EXPECT_NEAR(r.m.axis(a).position(), target[a], kOneCount) << "axis " << a;
    EXPECT_NEAR(r.counted(a, initial[a]), target[a], kOneCount) << "axis " << a;
    EXPECT_NEAR(r.m.axis(a).velocity(), 0.0, 1e-9) << "axis " << a;
  }
  const auto s = r.m.state();
  EXPECT_TRUE(s.axes[0].drives[0].enabled);
  EXPECT_FALSE(s.axes[2].brakeEngaged);
  EXPECT_TRUE(s.estopOk);
}

// Enables off: the amplifier gives no torque whatever the analog output
// says, and the axis coasts to a stop on its friction.
TEST(Machine, EnablesOffTheAxisCoastsToAStop) {
  Rig r;
  r.setEnable(true);
  r.setVolts(0, 4.0);  // 100 mm/s
  for (int i = 0; i < 300; ++i) r.cycle();
  EXPECT_NEAR(r.m.axis(0).velocity(), 100.0, 0.5);
  r.setEnable(false);
  double last = r.m.axis(0).velocity(), where = r.m.axis(0).position();
  int stoppedAt = -1;
  for (int i = 0; i < 1000; ++i) {
    r.cycle();
    const double v = r.m.axis(0).velocity();
    ASSERT_LE(v, last + 1e-12) << "cycle " << i;  // slowing down only
    ASSERT_GE(v, 0.0);
    if (v == 0.0 && stoppedAt < 0) stoppedAt = i;
    last = v;
  }
  const auto s = r.m.state();
  EXPECT_FALSE(s.axes[0].drives[0].enaOn);
  EXPECT_FALSE(s.axes[0].drives[0].enabled);
  EXPECT_EQ(s.axes[0].drives[0].torque, 0.0);
  EXPECT_NEAR(s.axes[0].drives[0].commandVolts, 4.0, 0.01);  // the 7I77 still puts it out
  EXPECT_GT(stoppedAt, 5);    // it coasted
  EXPECT_LT(stoppedAt, 1000);  // and stopped
  EXPECT_GT(r.m.axis(0).position(), where + 1.0);
}

// The host stops: 50 ms later both 7I77 watchdogs bite (manual: ANALOG
// SECTION WATCHDOG, FIELD I/O WATCHDOG AND FAULTS); the drives lose their
// enables, X coasts to a stop and Z's brake drops in with its output.
TEST(Machine, WhenTheHostStopsTheWatchdogsStopTheMachine) {
  Rig r;
  r.setEnable(true);
  r.setOutputs(1U << 2);
  r.setVolts(0, 4.0);
  for (int i = 0; i < 300; ++i) r.cycle();
  EXPECT_GT(r.m.axis(0).velocity(), 90.0);
  for (int i = 0; i < 40; ++i) {  // no host cycles: only time passes
    r.m.advance(hm2::SimTime{r.rc.t.now() + 1ms});
    r.rc.t.sleep(1ms);
  }
  EXPECT_TRUE(r.m.state().axes[0].drives[0].enabled);  // 40 ms: not yet
  for (int i = 0; i < 1000; ++i) {
    r.m.advance(hm2::SimTime{r.rc.t.now() + 1ms});
    r.rc.t.sleep(1ms);
  }
  const auto s = r.m.state();
  EXPECT_FALSE(s.axes[0].drives[0].enabled);
  EXPECT_EQ(s.axes[0].drives[0].commandVolts, 0.0);
  EXPECT_EQ(s.axes[0].velocity, 0.0);
  EXPECT_TRUE(s.axes[2].brakeEngaged);
  EXPECT_EQ(s.axes[2].velocity, 0.0);
}

// Limit and home switches change state as the axis passes them, and the
// host sees it within a cycle or two; past the switches the axis meets its
// hard stop.
TEST(Machine, SwitchesTripWhereTheAxisPassesThem) {
  auto d = machine::mill();
  d.axes[0].initialPosition = 380.0;
  Rig r(d);
  EXPECT_FALSE(r.in(0));  // x-home: normally open, not yet on the cam
  EXPECT_TRUE(r.in(1));   // x-min: normally closed, inside
  EXPECT_TRUE(r.in(2));   // x-max
  EXPECT_TRUE(r.in(9));   // E-stop chain closed
  r.setEnable(true);
  r.setVolts(0, 1.0);  // 25 mm/s
  double homeAt = 0, maxAt = 0;
  for (int i = 0; i < 2000 && maxAt == 0; ++i) {
    r.cycle();
    const double x = r.m.axis(0).position();
    if (homeAt == 0 && r.in(0)) homeAt = x;
    if (maxAt == 0 && !r.in(2)) maxAt = x;
  }
  // Seen by the host within two periods of passing (25 mm/s: 0.025 mm each).
  EXPECT_GE(homeAt, 395.0);
  EXPECT_LT(homeAt, 395.0 + 0.06);
  EXPECT_GE(maxAt, 402.0);
  EXPECT_LT(maxAt, 402.0 + 0.06);
  const auto s = r.m.state();
  EXPECT_TRUE(s.axes[0].switches[0].tripped);
  EXPECT_FALSE(s.axes[0].switches[2].inputOn);
  // On to the hard stop at 405, where the axis stops dead.
  for (int i = 0; i < 500; ++i) r.cycle();
  EXPECT_DOUBLE_EQ(r.m.axis(0).position(), 405.0);
  EXPECT_TRUE(r.m.state().axes[0].atHardStop);
  // The E-stop button opens the chain.
  EXPECT_TRUE(r.m.setSwitch("estop", true));
  r.cycle();
  EXPECT_FALSE(r.in(9));
  EXPECT_FALSE(r.m.state().estopOk);
  EXPECT_FALSE(r.m.setSwitch("no-such-switch", true));
}

// Gravity pulls an unpowered Z down once its brake is released; the brake
// (released only while output 2 is on) holds it.
TEST(Machine, GravityPullsZDownAndTheBrakeHoldsIt) {
  Rig r;
  for (int i = 0; i < 1000; ++i) r.cycle();
  EXPECT_DOUBLE_EQ(r.m.axis(2).position(), -75.0);  // brake holding, drives off
  EXPECT_TRUE(r.m.state().axes[2].brakeEngaged);
  r.setOutputs(1U << 2);  // release it
  for (int i = 0; i < 200; ++i) r.cycle();
  const double fell = r.m.axis(2).position();
  EXPECT_LT(fell, -76.0);
  EXPECT_LT(r.m.axis(2).velocity(), 0.0);
  EXPECT_LT(r.counted(2, -75.0), -76.0);  // the encoder saw it
  r.setOutputs(0);  // brake on again: it stops the fall and holds
  for (int i = 0; i < 500; ++i) r.cycle();
  const double held = r.m.axis(2).position();
  EXPECT_EQ(r.m.axis(2).velocity(), 0.0);
  for (int i = 0; i < 500; ++i) r.cycle();
  EXPECT_DOUBLE_EQ(r.m.axis(2).position(), held);
  // X and Y have no gravity and no brake: they stayed.
  EXPECT_DOUBLE_EQ(r.m.axis(0).position(), 200.0);
}

// An axis whose count rate is past what the mux path resolves (about 2 MHz,
// manual: MAXIMUM ENCODER COUNT RATE) loses counts; a slow one loses none.
TEST(Machine, AnAxisFasterThanTheEncoderPathLosesCounts) {
  auto d = machine::mill();
  d.axes[0].drives[0].encoder.linesPerRev = 20000;  // 80000 counts/rev: 4 M counts/s at 10 V
  Rig r(d);
  r.setEnable(true);
  r.setVolts(0, 10.0);
  r.setVolts(1, -10.0);  // Y: 400 k counts/s
  for (int i = 0; i < 100; ++i) r.cycle();
  EXPECT_GT(std::abs(r.m.axis(0).velocity()), 200.0);
  // Stop both (the drives' loops hold them), so the counts are read at rest.
  r.setVolts(0, 0.0);
  r.setVolts(1, 0.0);
  for (int i = 0; i < 200; ++i) r.cycle();
  const auto s = r.m.state();
  const double trueX = s.axes[0].drives[0].trueCounts;
  const double trueY = s.axes[1].drives[0].trueCounts - 150.0 * kCountsPerMm;
  const auto countedX = static_cast<double>(r.enc.counts(0) - r.countsAtStart[0]) + 200.0 / 5.0 * 80000.0;
  const auto countedY = static_cast<double>(r.enc.counts(1) - r.countsAtStart[1]);
  EXPECT_GT(std::abs(countedX - trueX), 10000.0) << countedX << " vs " << trueX;
  EXPECT_LT(trueY, -20000.0);
  // The shaft between two counts: within one count of where it truly is.
  EXPECT_NEAR(countedY, trueY, 1.0) << countedY << " vs " << trueY;
}

// The index comes once a motor revolution (every 5 mm on the mill), at the
// same shaft angle each time: what index homing latches on.
TEST(Machine, TheIndexComesOnceAMotorRevolution) {
  Rig r;
  r.setEnable(true);
  r.setVolts(0, 0.2);  // 5 mm/s
  std::array<double, 2> at{};
  for (double& where : at) {
    r.enc.enableIndex(0);
    for (int i = 0; i < 1100 && r.enc.indexEnabled(0); ++i) r.cycle();
    ASSERT_FALSE(r.enc.indexEnabled(0));
    // The count was zeroed at the index: the true position less what has
    // been counted since is where the index was.
    where = r.m.axis(0).position() - static_cast<double>(r.enc.counts(0)) / kCountsPerMm;
  }
  EXPECT_NEAR(at[1] - at[0], 5.0, 2 * kOneCount);
}

// The index is a track of its own: counts an A or B channel missed while
// broken do not move it, so after the repair it comes at the same shaft
// angle as before (homing to it lands where it always did).
TEST(Machine, AMendedEncoderChannelLeavesTheIndexWhereItWas) {
  Rig r;
  r.setEnable(true);
  r.setVolts(0, 0.2);  // 5 mm/s
  auto indexPosition = [&] {
    r.enc.enableIndex(0);
    for (int i = 0; i < 1100 && r.enc.indexEnabled(0); ++i) r.cycle();
    EXPECT_FALSE(r.enc.indexEnabled(0));
    return r.m.axis(0).position() - static_cast<double>(r.enc.counts(0)) / kCountsPerMm;
  };
  const double before = indexPosition();
  r.m.setEncoderBroken(0, 0, machine::EncoderChannel::A, true);
  for (int i = 0; i < 333; ++i) r.cycle();  // 1.665 mm the count misses
  r.m.setEncoderBroken(0, 0, machine::EncoderChannel::A, false);
  const double after = indexPosition();
  const double revolutions = (after - before) / 5.0;  // one index a motor revolution, 5 mm
  EXPECT_NEAR(revolutions, std::round(revolutions), 2 * kOneCount / 5.0) << before << " then " << after;
}

// The spindle: SpinEna runs the VFD, which ramps to rpm-per-volt; its
// encoder counts the turns.
TEST(Machine, SpindleRampsToSpeedAndItsEncoderCounts) {
  Rig r;
  r.setVolts(5, 5.0);  // 12000 rpm
  for (int i = 0; i < 100; ++i) r.cycle();
  EXPECT_EQ(r.m.state().spindle->rpm, 0.0);  // SpinEna off
  r.rc.ss.setRaw(r.spin, 1);
  for (int i = 0; i < 2000; ++i) r.cycle();
  const auto s = r.m.state();
  EXPECT_TRUE(s.spindle->running);
  EXPECT_NEAR(s.spindle->rpm, 12000.0, 10.0);  // DAC resolution
  EXPECT_NEAR(r.enc.velocity(5), s.spindle->rpm / 60.0 * 1024.0, 1000.0);
}

// The same host inputs give the same machine, to the last bit.
TEST(Machine, TwoRunsGiveIdenticalState) {
  auto run = [] {
    Rig r;
    r.setEnable(true);
    r.setOutputs(1U << 2);
    r.rc.ss.setRaw(r.spin, 1);
    r.setVolts(5, 3.0);
    for (int i = 0; i < 700; ++i) {
      r.setVolts(0, clampVolts(5.0 * (260.0 - r.counted(0, 200.0))));
      r.setVolts(1, clampVolts(5.0 * (100.0 - r.counted(1, 150.0))));
      r.setVolts(2, std::sin(i / 50.0));
      r.cycle();
    }
    return r.m.state();
  };
  const auto a = run();
  const auto b = run();
  EXPECT_EQ(a, b);
  EXPECT_GT(a.axes[0].position, 201.0);
}

TEST(Machine, WiringTheSevenI77DoesNotHaveIsAnError) {
  hm2::HostMot2Card card;
  auto d = machine::mill();
  d.axes[0].drives[0].analogOutput = 6;
  EXPECT_THROW(Machine(d, card), std::invalid_argument);
  d = machine::mill();
  d.switches[0].axis = "w";
  EXPECT_THROW(Machine(d, card), std::invalid_argument);
  d = machine::mill();
  d.switches[0].input = 32;
  EXPECT_THROW(Machine(d, card), std::invalid_argument);
  for (const auto& good : {machine::mill(), machine::lathe(), machine::gantry()}) EXPECT_NO_THROW(Machine(good, card));
}

// A machine whose drives are off and whose axes stand rests: time passes
// over it in one go, and nothing changes; enabled, it moves again at once.
TEST(Machine, AnIdleMachineRestsUntilItsDrivesAreEnabled) {
  Rig r;
  for (int i = 0; i < 5; ++i) r.cycle();
  EXPECT_TRUE(r.m.resting());
  auto before = r.m.state();
  const hm2::SimTime later{r.rc.t.now() + 30ms};  // within the 7I77's 50 ms watchdog
  r.m.advance(later);
  EXPECT_EQ(r.m.time(), later);
  auto after = r.m.state();
  after.time = before.time;
  EXPECT_EQ(after, before) << "a resting machine does not change";
  r.rc.t.sleep(later - hm2::SimTime{r.rc.t.now()});
  r.setEnable(true);
  r.setVolts(0, 1.0);  // 25 mm/s
  r.cycle();  // the command reaches the 7I77 in this period
  EXPECT_FALSE(r.m.resting());
  for (int i = 0; i < 100; ++i) r.cycle();
  EXPECT_NEAR(r.m.state().axes[0].velocity, 25.0, 0.5);
}

// The gantry: two motors on one beam, each with its own encoder.
TEST(Machine, GantryDrivesOneAxisWithTwoMotors) {
  Rig r(machine::gantry());
  r.setEnable(true);
  r.setVolts(1, 2.0);
  r.setVolts(2, 2.0);
  for (int i = 0; i < 500; ++i) r.cycle();
  const auto s = r.m.state();
  ASSERT_EQ(s.axes[1].drives.size(), 2U);
  EXPECT_NEAR(s.axes[1].velocity, 2.0 * 5.0 * 10.0, 0.5);  // 10 mm/rev
  // One shaft, two counters: the host reads them one after the other, so
  // an edge may fall between the two reads.
  EXPECT_LE(std::abs((r.enc.counts(1) - r.countsAtStart[1]) - (r.enc.counts(2) - r.countsAtStart[2])), 1);
  EXPECT_GT(r.enc.counts(1) - r.countsAtStart[1], 10000);
}

// An outside force pushes the axis whatever its motor does: the encoder
// counts the motion, and the amplifier's following error shows it.
TEST(MachineFaults, APushMovesTheAxisWhateverTheMotorDoes) {
  Rig r;
  r.setEnable(true);  // X held at zero speed by its drive's velocity loop
  for (int i = 0; i < 50; ++i) r.cycle();
  EXPECT_EQ(r.m.followingError(0), 0.0);
  r.m.push(0, 3.0, 20.0);  // 150 ms
  for (int i = 0; i < 100; ++i) r.cycle();
  auto s = r.m.state();
  EXPECT_TRUE(s.axes[0].pushing);
  EXPECT_NEAR(s.axes[0].velocity, 20.0, 1e-9);
  EXPECT_NEAR(r.m.axis(0).position(), 202.0, 0.001);
  for (int i = 0; i < 51; ++i) r.cycle();
  s = r.m.state();
  EXPECT_FALSE(s.axes[0].pushing);
  // Let go, the drive (its loop wound up against the push) pulls back a little.
  EXPECT_NEAR(s.axes[0].position, 203.0, 0.01);
  // It was asked for zero speed all along: it is 3 mm off where it was told to be.
  EXPECT_NEAR(s.axes[0].followingError, 200.0 - s.axes[0].position, 1e-9);
  EXPECT_LT(s.axes[0].followingError, -2.99);
  r.setEnable(false);  // coasts to rest: counted where it is
  for (int i = 0; i < 100; ++i) r.cycle();
  EXPECT_EQ(r.m.axis(0).velocity(), 0.0);
  EXPECT_NEAR(r.counted(0, 200.0), r.m.axis(0).position(), kOneCount);
  EXPECT_THROW(r.m.push(0, 1.0, 0.0), std::invalid_argument);
  EXPECT_THROW(r.m.push(3, 1.0, 1.0), std::out_of_range);
}

// Pushed past its limit switch the host sees the limit open; the hard stop
// ends the push.
TEST(MachineFaults, APushedAxisTripsItsLimitAndStopsAtTheHardStop) {
  auto d = machine::mill();
  d.axes[0].initialPosition = 395.5;
  Rig r(d);
  EXPECT_TRUE(r.in(2));
  r.m.push(0, 20.0, 50.0);
  bool opened = false;
  for (int i = 0; i < 400; ++i) {
    r.cycle();
    if (!r.in(2) && !opened) {
      opened = true;
      EXPECT_NEAR(r.m.axis(0).position(), 402.0, 0.11);  // seen within two 50 um cycles
    }
  }
  EXPECT_TRUE(opened);
  const auto s = r.m.state();
  EXPECT_DOUBLE_EQ(s.axes[0].position, 405.0);
  EXPECT_TRUE(s.axes[0].atHardStop);
  EXPECT_FALSE(s.axes[0].pushing);
  EXPECT_EQ(s.axes[0].velocity, 0.0);
}

// A jammed axis stays put whatever its drive does, and moves again when freed.
TEST(MachineFaults, AJammedAxisDoesNotMoveUntilFreed) {
  Rig r;
  r.setEnable(true);
  r.setVolts(0, 4.0);  // 100 mm/s
  for (int i = 0; i < 100; ++i) r.cycle();
  r.m.setJammed(0, true);
  for (int i = 0; i < 2; ++i) r.cycle();  // the host has read the last counts
  const double at = r.m.axis(0).position();
  const auto counts = r.enc.counts(0);
  const double error = r.m.followingError(0);
  r.m.push(0, 5.0, 20.0);  // waits while jammed
  for (int i = 0; i < 500; ++i) r.cycle();
  auto s = r.m.state();
  EXPECT_TRUE(s.axes[0].jammed);
  EXPECT_TRUE(s.axes[0].pushing);
  EXPECT_EQ(s.axes[0].position, at);
  EXPECT_EQ(s.axes[0].velocity, 0.0);
  EXPECT_EQ(r.enc.counts(0), counts);
  EXPECT_GT(s.axes[0].drives[0].torque, 1.0);          // the drive strains against it
  EXPECT_NEAR(r.m.followingError(0), error + 50.0, 0.1);  // 0.5 s at 100 mm/s asked for
  r.m.setJammed(0, false);
  for (int i = 0; i < 300; ++i) r.cycle();  // the push, 250 ms, then the drive again
  s = r.m.state();
  EXPECT_FALSE(s.axes[0].jammed);
  EXPECT_FALSE(s.axes[0].pushing);
  EXPECT_GT(s.axes[0].position, at + 5.0 + 1.0);
}

// A broken A (or B) channel: the count stops following the shaft; mended,
// it counts again from where it stopped, the motion in between lost.
TEST(MachineFaults, ABrokenEncoderChannelStopsTheCount) {
  for (const auto channel : {machine::EncoderChannel::A, machine::EncoderChannel::B}) {
    Rig r;
    r.setEnable(true);
    r.setVolts(0, 0.4);  // 10 mm/s
    for (int i = 0; i < 100; ++i) r.cycle();
    r.m.setEncoderBroken(0, 0, channel, true);
    for (int i = 0; i < 2; ++i) r.cycle();  // the host has read the last counts
    const auto stuck = r.enc.counts(0);
    const double from = r.m.axis(0).position();
    for (int i = 0; i < 200; ++i) r.cycle();
    EXPECT_NEAR(r.m.axis(0).position(), from + 2.0, 0.02);  // it moved 2 mm
    EXPECT_EQ(r.enc.counts(0), stuck);                       // uncounted
    auto s = r.m.state();
    ASSERT_EQ(s.axes[0].drives[0].encoderBroken.size(), 1U);
    EXPECT_EQ(s.axes[0].drives[0].encoderBroken[0], channel);
    r.m.setEncoderBroken(0, 0, channel, false);
    r.cycle();  // the host reads counts of a cycle before the position: from here on, always
    const auto mended = r.enc.counts(0);
    const double at = r.m.axis(0).position();
    for (int i = 0; i < 200; ++i) r.cycle();
    EXPECT_NEAR(static_cast<double>(r.enc.counts(0) - mended) / kCountsPerMm, r.m.axis(0).position() - at, 2 * kOneCount);
    EXPECT_TRUE(r.m.state().axes[0].drives[0].encoderBroken.empty());
  }
}

// A broken index channel: no index comes, so index homing waits; mended, it comes.
TEST(MachineFaults, ABrokenIndexGivesNoIndexPulse) {
  Rig r;
  r.setEnable(true);
  r.setVolts(0, 0.4);  // 10 mm/s: a motor revolution every 0.5 s
  r.m.setEncoderBroken(0, 0, machine::EncoderChannel::Index, true);
  r.enc.enableIndex(0);
  for (int i = 0; i < 1200; ++i) r.cycle();
  EXPECT_TRUE(r.enc.indexEnabled(0));  // 12 mm, two revolutions: nothing
  const auto s = r.m.state();
  ASSERT_EQ(s.axes[0].drives[0].encoderBroken.size(), 1U);
  EXPECT_EQ(s.axes[0].drives[0].encoderBroken[0], machine::EncoderChannel::Index);
  r.m.setEncoderBroken(0, 0, machine::EncoderChannel::Index, false);
  for (int i = 0; i < 600 && r.enc.indexEnabled(0); ++i) r.cycle();
  EXPECT_FALSE(r.enc.indexEnabled(0));
  // The spindle's encoder too.
  EXPECT_TRUE(r.m.setSpindleEncoderBroken(machine::EncoderChannel::Index, true));
  ASSERT_EQ(r.m.state().spindle->encoderBroken.size(), 1U);
  EXPECT_THROW(r.m.setEncoderBroken(0, 1, machine::EncoderChannel::A, true), std::out_of_range);
}

// A and B swapped (the encoder reversed): from the change on the count runs
// against the motion, going on from where it was (no jump); put right, it
// runs with the motion again.
TEST(MachineFaults, AReversedEncoderCountsAgainstTheMotionWithoutAJump) {
  Rig r;
  r.setEnable(true);
  r.setVolts(0, 0.4);  // 10 mm/s: 16 counts a cycle
  for (int i = 0; i < 100; ++i) r.cycle();
  // The counts each cycle adds.
  auto steps = [&](int cycles) {
    std::vector<double> out;
    for (int i = 0; i < cycles; ++i) {
      const auto before = r.enc.counts(0);
      r.cycle();
      out.push_back(static_cast<double>(r.enc.counts(0) - before));
    }
    return out;
  };
  for (const auto d : steps(10)) EXPECT_NEAR(d, 16, 1);
  r.m.setEncoderReversed(0, 0, true);
  EXPECT_TRUE(r.m.state().axes[0].drives[0].encoderReversed);
  const auto counted = r.enc.counts(0);
  const double from = r.m.axis(0).position();
  auto after = steps(200);
  for (std::size_t i = 0; i < after.size(); ++i) ASSERT_LE(std::abs(after[i]), 17.0) << "cycle " << i;
  for (std::size_t i = 2; i < after.size(); ++i) ASSERT_NEAR(after[i], -16, 1) << "cycle " << i;
  // Two cycles' motion at most counted forward: the span the encoder was
  // already aimed over when it changed, and the cycle the host reads behind.
  const double moved = r.m.axis(0).position() - from;
  EXPECT_NEAR(moved, 2.0, 0.02);
  EXPECT_NEAR(static_cast<double>(r.enc.counts(0) - counted), -moved * kCountsPerMm, 2 * 16 + 2);
  r.m.setEncoderReversed(0, 0, false);
  EXPECT_FALSE(r.m.state().axes[0].drives[0].encoderReversed);
  after = steps(20);
  for (std::size_t i = 0; i < after.size(); ++i) ASSERT_LE(std::abs(after[i]), 17.0) << "cycle " << i;
  for (std::size_t i = 2; i < after.size(); ++i) ASSERT_NEAR(after[i], 16, 1) << "cycle " << i;
  // The spindle's encoder too; a drive the axis lacks is out of range.
  EXPECT_TRUE(r.m.setSpindleEncoderReversed(true));
  EXPECT_TRUE(r.m.state().spindle->encoderReversed);
  EXPECT_THROW(r.m.setEncoderReversed(0, 1, true), std::out_of_range);
}

// The index track is on the shaft: reversed, the encoder's index comes at
// the same shaft angle, so homing to it lands a whole motor revolution
// from where it did.
TEST(MachineFaults, AReversedEncoderLeavesTheIndexWhereItWas) {
  Rig r;
  r.setEnable(true);
  r.setVolts(0, 0.2);  // 5 mm/s
  // Where the axis was when the index cleared the count; `direction`: the
  // count's, +1 or -1 a forward count.
  auto indexPosition = [&](double direction) {
    r.enc.enableIndex(0);
    for (int i = 0; i < 1100 && r.enc.indexEnabled(0); ++i) r.cycle();
    EXPECT_FALSE(r.enc.indexEnabled(0));
    return r.m.axis(0).position() - direction * static_cast<double>(r.enc.counts(0)) / kCountsPerMm;
  };
  const double before = indexPosition(1.0);
  for (int i = 0; i < 333; ++i) r.cycle();  // a third of a revolution on
  r.m.setEncoderReversed(0, 0, true);
  const double reversed = indexPosition(-1.0);
  for (int i = 0; i < 150; ++i) r.cycle();
  r.m.setEncoderReversed(0, 0, false);
  const double mended = indexPosition(1.0);
  for (const double at : {reversed, mended}) {
    const double revolutions = (at - before) / 5.0;  // one index a motor revolution, 5 mm
    EXPECT_GE(revolutions, 0.5);
    EXPECT_NEAR(revolutions, std::round(revolutions), 2 * kOneCount / 5.0) << before << " then " << at;
  }
}

// Reversed, the encoder turns the position loop into positive feedback: the
// axis a P loop held runs away from its target (manual: CAUTION).
TEST(MachineFaults, AReversedEncoderMakesThePositionLoopRunAway) {
  Rig r;
  constexpr double initial = 200.0, kp = 5.0;  // V per mm
  double target = initial;
  r.setEnable(true);
  auto loop = [&](int cycles) {
    for (int i = 0; i < cycles; ++i) {
      r.setVolts(0, clampVolts(kp * (target - r.counted(0, initial))));
      r.cycle();
    }
  };
  loop(200);
  EXPECT_NEAR(r.m.axis(0).position(), initial, kOneCount);
  r.m.setEncoderReversed(0, 0, true);
  target = initial + 1.0;
  loop(200);
  EXPECT_GT(r.m.axis(0).position(), initial + 20.0);  // 10 V, 250 mm/s, away
  EXPECT_LT(r.counted(0, initial), initial - 20.0);   // counted the other way
}

// An amplifier whose enable input does nothing (a jumpered enable): with
// ENA off it still follows its analog command and holds still at 0 V; put
// right, ENA rules it again and the axis coasts to a stop.
TEST(MachineFaults, AnAmplifierIgnoringItsEnableRunsWithEnaOff) {
  Rig r;
  r.setEnable(false);
  r.setVolts(0, 0.4);  // 10 mm/s
  for (int i = 0; i < 100; ++i) r.cycle();
  EXPECT_EQ(r.m.axis(0).velocity(), 0.0);
  EXPECT_FALSE(r.m.state().axes[0].drives[0].enabled);
  r.m.setEnableIgnored(0, 0, true);
  for (int i = 0; i < 300; ++i) r.cycle();
  auto s = r.m.state();
  EXPECT_FALSE(s.axes[0].drives[0].enaOn);
  EXPECT_TRUE(s.axes[0].drives[0].enabled);
  EXPECT_TRUE(s.axes[0].drives[0].enableIgnored);
  EXPECT_FALSE(s.axes[1].drives[0].enableIgnored);
  EXPECT_NEAR(s.axes[0].velocity, 10.0, 0.1);
  EXPECT_NEAR(r.m.commandVelocity(0), 10.0, 0.05);  // the 7I77 DAC's steps
  r.setVolts(0, 0.0);
  for (int i = 0; i < 300; ++i) r.cycle();
  const double held = r.m.axis(0).position();
  for (int i = 0; i < 300; ++i) r.cycle();
  EXPECT_NEAR(r.m.axis(0).velocity(), 0.0, 1e-3);
  EXPECT_NEAR(r.m.axis(0).position(), held, 1e-3);
  EXPECT_FALSE(r.m.resting());  // powered, holding
  r.setVolts(0, 0.4);
  for (int i = 0; i < 100; ++i) r.cycle();
  EXPECT_NEAR(r.m.axis(0).velocity(), 10.0, 0.1);
  r.m.setEnableIgnored(0, 0, false);
  for (int i = 0; i < 1000; ++i) r.cycle();
  s = r.m.state();
  EXPECT_FALSE(s.axes[0].drives[0].enabled);
  EXPECT_FALSE(s.axes[0].drives[0].enableIgnored);
  EXPECT_EQ(s.axes[0].velocity, 0.0);  // coasted to a stop
  EXPECT_THROW(r.m.setEnableIgnored(0, 1, true), std::out_of_range);
}

// The host stops with such a drive commanded to move: 50 ms later the
// 7I77's watchdog drops ENA and takes AOUT to 0 V (manual: ANALOG SECTION
// WATCHDOG). ENA does nothing to the drive; the 0 V stops it, and it holds
// the axis there, powered.
TEST(MachineFaults, AnAmplifierIgnoringItsEnableStopsOnTheWatchdogsZeroVolts) {
  Rig r;
  r.setEnable(true);
  r.setVolts(0, 4.0);  // 100 mm/s
  r.m.setEnableIgnored(0, 0, true);
  for (int i = 0; i < 300; ++i) r.cycle();
  EXPECT_NEAR(r.m.axis(0).velocity(), 100.0, 0.5);
  for (int i = 0; i < 1000; ++i) {  // no host cycles: only time passes
    r.m.advance(hm2::SimTime{r.rc.t.now() + 1ms});
    r.rc.t.sleep(1ms);
  }
  const auto s = r.m.state();
  EXPECT_FALSE(s.axes[0].drives[0].enaOn);
  EXPECT_TRUE(s.axes[0].drives[0].enabled);
  EXPECT_EQ(s.axes[0].drives[0].commandVolts, 0.0);
  EXPECT_NEAR(s.axes[0].velocity, 0.0, 1e-3);
  EXPECT_FALSE(r.m.resting());
}

// The E-stop button opens the chain's normally closed input; the probe closes its own.
TEST(MachineFaults, EstopAndProbeByKind) {
  Rig r;
  EXPECT_TRUE(r.in(9));
  EXPECT_FALSE(r.in(10));
  EXPECT_EQ(r.m.setSwitches(machine::SwitchKind::Estop, true), 1U);
  EXPECT_EQ(r.m.setSwitches(machine::SwitchKind::Probe, true), 1U);
  r.cycle();
  EXPECT_FALSE(r.in(9));
  EXPECT_TRUE(r.in(10));
  auto s = r.m.state();
  EXPECT_FALSE(s.estopOk);
  EXPECT_TRUE(s.probe);
  r.m.setSwitches(machine::SwitchKind::Estop, false);
  r.m.setSwitches(machine::SwitchKind::Probe, false);
  r.cycle();
  EXPECT_TRUE(r.in(9));
  EXPECT_FALSE(r.in(10));
  EXPECT_EQ(r.m.setSwitches(machine::SwitchKind::Other, true), 0U);
  EXPECT_TRUE(r.m.setSwitch("x-max", true));  // stuck tripped
  r.cycle();
  EXPECT_FALSE(r.in(2));
}

// The trace row: what the amplifiers are told and what the axes do.
TEST(MachineTrace, ARowHoldsEveryAxisCommandPositionAndFollowingError) {
  Rig r;
  const auto columns = r.m.traceColumns();
  ASSERT_EQ(columns.size(), 1U + 3U * 6U + 1U);
  EXPECT_EQ(columns[0], "time_s");
  EXPECT_EQ(columns[1], "x_command_volts");
  EXPECT_EQ(columns[2], "x_command_velocity");
  EXPECT_EQ(columns[3], "x_position");
  EXPECT_EQ(columns[4], "x_velocity");
  EXPECT_EQ(columns[5], "x_following_error");
  EXPECT_EQ(columns[6], "x_enabled");
  EXPECT_EQ(columns[7], "y_command_volts");
  EXPECT_EQ(columns[17], "z_following_error");
  EXPECT_EQ(columns[18], "z_enabled");
  EXPECT_EQ(columns[19], "spindle_rpm");
  r.setEnable(true);
  r.setVolts(0, 2.0);  // 50 mm/s
  for (int i = 0; i < 300; ++i) r.cycle();
  std::vector<double> row(columns.size());
  r.m.traceRow(row);
  EXPECT_NEAR(row[0], std::chrono::duration<double>(r.m.time()).count(), 1e-12);
  EXPECT_NEAR(row[1], 2.0, 0.01);
  EXPECT_NEAR(row[2], 50.0, 0.2);
  EXPECT_EQ(row[3], r.m.axis(0).position());
  EXPECT_NEAR(row[4], 50.0, 0.2);
  // The drive lags its command while it accelerates, then keeps pace.
  EXPECT_LT(row[5], 0.5);
  EXPECT_GT(row[5], 0.0);
  EXPECT_EQ(row[6], 1.0);   // enabled
  EXPECT_EQ(row[11], 0.0);  // Y: enabled, told 0 V, holding: no error
  EXPECT_EQ(row[12], 1.0);
  r.setEnable(false);
  r.cycle();
  r.m.traceRow(row);
  EXPECT_EQ(row[2], 0.0);
  EXPECT_EQ(row[5], 0.0);  // disabled: nothing asked
  EXPECT_EQ(row[6], 0.0);
  EXPECT_EQ(row[12], 0.0);
  // The amplifier as it runs: one ignoring its enable is enabled with ENA off.
  r.m.setEnableIgnored(1, 0, true);
  r.m.traceRow(row);
  EXPECT_EQ(row[6], 0.0);
  EXPECT_EQ(row[12], 1.0);
}

}  // namespace
