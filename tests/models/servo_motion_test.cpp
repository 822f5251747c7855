// SPDX-License-Identifier: MIT
// The servo axis solved exactly between events (machine/servo_motion.hpp)
// against the fixed-step reference (tests/support/fixed_step_plant.hpp) at
// 1 us and 4 us steps, side by side over the same commands at 1 kHz: a position
// loop on the mill's axes, a drive saturating, stick-slip, a vertical axis
// falling onto its hard stop, a gantry. Each run also asserts what the
// scenario is for (events found, the stop reached), so that a comparison
// of two resting axes cannot pass for one of two moving ones.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <span>
#include <vector>

#include "hostmot2/card.hpp"
#include "machine/machine.hpp"
#include "machine/machine_file.hpp"
#include "machine/servo_motion.hpp"
#include "support/fixed_step_plant.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace machine = lbpkit::model::machine;

namespace {

using namespace std::chrono_literals;
using machine::AmplifierParameters;
using machine::AxisParameters;

constexpr double kPeriod = 1e-3;          // the host's servo period
constexpr double kTwoPiPerSecond = machine::kTwoPi;  // 1 Hz in rad/s

// What a scenario's host puts out at each period's start, from where the
// axis is: volts per drive, the enables, the brake.
struct Output {
  std::vector<double> volts;
  std::vector<bool> ena;
  bool brake = false;
};
using Law = std::function<Output(int period, double position, double velocity)>;

struct Compared {
  double maxPositionError = 0.0;  // machine units
  double maxVelocityError = 0.0;  // machine units per second
  double exactPosition = 0.0, referencePosition = 0.0;
  double exactVelocity = 0.0;
  double farthest = 0.0;  // the exact axis' largest distance from its start
  std::uint64_t events = 0;
};

// The exact solution and the reference at step `h` over `periods`, the law
// closed on each one's own position.
Compared compareAt(double h, const AxisParameters& p, const std::vector<AmplifierParameters>& amps, double start,
                   int periods, const Law& law) {
  std::vector<machine::ServoAmplifier> amplifiers;
  std::vector<test_support::FixedStepAxis::Drive> referenceDrives;
  const double share = p.inertia / static_cast<double>(amps.size());
  for (const auto& a : amps) {
    amplifiers.emplace_back(a);
    referenceDrives.push_back({a, share});
  }
  machine::Axis axis(p, start);
  machine::ServoMotion motion;
  test_support::FixedStepAxis reference(p, referenceDrives, start);
  Compared c;
  for (int k = 0; k < periods; ++k) {
    const Output exactOut = law(k, axis.position(), axis.velocity());
    std::vector<machine::ServoDrive> drives;
    for (std::size_t i = 0; i < amps.size(); ++i)
      drives.push_back({&amplifiers[i], exactOut.volts[i], exactOut.ena[i], share, 0.0});
    motion.advance(axis, drives, exactOut.brake, std::chrono::microseconds(1000));
    const Output refOut = law(k, reference.position(), reference.velocity());
    reference.run(refOut.volts, refOut.ena, refOut.brake, kPeriod, h);
    c.maxPositionError = std::max(c.maxPositionError, std::abs(axis.position() - reference.position()));
    c.maxVelocityError = std::max(c.maxVelocityError, std::abs(axis.velocity() - reference.velocity()));
    c.farthest = std::max(c.farthest, std::abs(axis.position() - start));
  }
  c.exactPosition = axis.position();
  c.referencePosition = reference.position();
  c.exactVelocity = axis.velocity();
  c.events = motion.events();
  return c;
}

// The comparison at a 1 us reference step, and the check that the
// difference is the reference's error: at a 4 us step it is about four
// times as large (the fixed-step integrator is first order), so the exact
// solution is what the reference converges to.
Compared compare(const AxisParameters& p, const std::vector<AmplifierParameters>& amps, double start, int periods,
                 const Law& law) {
  const Compared coarse = compareAt(4e-6, p, amps, start, periods, law);
  const Compared fine = compareAt(1e-6, p, amps, start, periods, law);
  if (fine.maxPositionError > 1e-7) {
    EXPECT_GT(coarse.maxPositionError / fine.maxPositionError, 2.5)
        << "4 us: " << coarse.maxPositionError << " mm, 1 us: " << fine.maxPositionError << " mm";
  }
  return fine;
}

// The built-in mill's axis `i` as the machine builds it.
struct MillAxis {
  AxisParameters p;
  AmplifierParameters amp;
};
MillAxis millAxis(std::size_t i) {
  hm2::HostMot2Card card;
  const machine::Machine m(machine::mill(), card);
  return {m.axis(i).parameters(), m.description().axes[i].drives[0].amplifier};
}

// A position loop (volts per mm of error) following a triangle wave of
// +-20 mm at 20 mm/s about `centre`, turning every 2 s.
Law triangle(double centre, double voltsPerMm) {
  return [=](int k, double position, double) {
    const double t = k * kPeriod;
    const double phase = std::fmod(t, 4.0);
    const double target = centre + (phase < 2.0 ? -20.0 + 20.0 * phase : 20.0 - 20.0 * (phase - 2.0));
    return Output{{std::clamp(voltsPerMm * (target - position), -10.0, 10.0)}, {true}, false};
  };
}

TEST(ServoMotion, FollowsTheReferenceInTheMillsPositionLoop) {
  for (std::size_t i : {0U, 2U}) {  // X, and Z (vertical, its brake released while enabled)
    const MillAxis a = millAxis(i);
    const double centre = (a.p.hardStopMin + a.p.hardStopMax) / 2.0;
    const Compared c = compare(a.p, {a.amp}, centre - 20.0, 6000, triangle(centre, 4.0));
    SCOPED_TRACE(i);
    EXPECT_LT(c.maxPositionError, 3e-5) << "mm";
    EXPECT_LT(c.maxVelocityError, 0.005) << "mm/s";
    // It moved: the triangle's two turns, at 20 mm/s at the end.
    EXPECT_NEAR(std::abs(c.exactVelocity), 20.0, 1.0);
  }
}

TEST(ServoMotion, FollowsTheReferenceThroughSaturationAndItsIntegratorLimit) {
  // 10 V from rest asks 50 rev/s: the drive gives its peak torque until
  // the speed nears the command, its integrator at its limit meanwhile;
  // then -10 V, and the same the other way.
  const MillAxis a = millAxis(0);
  const Compared c = compare(a.p, {a.amp}, 0.0, 400, [](int k, double, double) {
    return Output{{k < 200 ? 10.0 : -10.0}, {true}, false};
  });
  EXPECT_LT(c.maxPositionError, 3e-4) << "mm";
  EXPECT_LT(c.maxVelocityError, 0.04) << "mm/s";
  EXPECT_NEAR(c.exactVelocity, -250.0, 1.0);  // 50 rev/s of a 5 mm screw
  EXPECT_GE(c.events, 4U) << "saturating, its integrator at the limit, and back, each way";
}

TEST(ServoMotion, FollowsTheReferenceThroughStickSlip) {
  // A torque-mode drive whose torque swings a little past what Coulomb
  // friction holds: the axis sticks, breaks away, stops dead, twice a cycle.
  const MillAxis a = millAxis(0);
  AmplifierParameters torque = a.amp;
  torque.mode = machine::AmplifierMode::Torque;
  torque.gain = 0.1;  // Nm per volt
  torque.limit = 1.0;
  const double holding = a.p.coulomb;
  const Compared c = compare(a.p, {torque}, 0.0, 2000, [&](int k, double, double) {
    return Output{{1.5 * holding / 0.1 * std::sin(kTwoPiPerSecond * k * kPeriod)}, {true}, false};
  });
  EXPECT_LT(c.maxPositionError, 3e-5) << "mm";
  EXPECT_LT(c.maxVelocityError, 2e-4) << "mm/s";
  // Friction stops it within a period, twice a cycle; it breaks away at a
  // period's start, where the torque changes (no event: the piece is
  // chosen there anyway).
  EXPECT_GE(c.events, 4U) << "a rest each way, each cycle";
  EXPECT_GT(c.farthest, 0.01) << "it moved";
}

TEST(ServoMotion, FollowsTheReferenceAsAVerticalAxisFallsOntoItsHardStop) {
  // Z disabled and its brake released: gravity beats friction and it falls
  // onto the hard stop below, where it stays; then the brake engages.
  const MillAxis a = millAxis(2);
  ASSERT_GT(a.p.gravityTorque, a.p.coulomb);
  const double start = a.p.hardStopMin + 1.0;
  const Compared c = compare(a.p, {a.amp}, start, 300, [](int k, double, double) {
    return Output{{0.0}, {false}, k >= 250};
  });
  EXPECT_LT(c.maxPositionError, 1e-5) << "mm";
  EXPECT_DOUBLE_EQ(c.exactPosition, a.p.hardStopMin);
  EXPECT_DOUBLE_EQ(c.referencePosition, a.p.hardStopMin);
  EXPECT_EQ(c.exactVelocity, 0.0);
}

TEST(ServoMotion, FollowsTheReferenceWithTwoDrivesOnOneAxis) {
  hm2::HostMot2Card card;
  const machine::Machine m(machine::gantry(), card);
  const AxisParameters p = m.axis(1).parameters();
  const auto& drives = m.description().axes[1].drives;
  ASSERT_EQ(drives.size(), 2U);
  // The two drives put out slightly different volts, as two loops would.
  const Compared c = compare(p, {drives[0].amplifier, drives[1].amplifier}, 100.0, 1500, [](int k, double, double) {
    const double v = k < 700 ? 2.0 : -1.0;
    return Output{{v, v * 1.02}, {true, true}, false};
  });
  EXPECT_LT(c.maxPositionError, 1.5e-4) << "mm";
  EXPECT_LT(c.maxVelocityError, 0.04) << "mm/s";
  EXPECT_LT(c.exactVelocity, -40.0);
}

}  // namespace

namespace {

// Exact at any span: the same commands over a second split into spans of
// any lengths (as the daemon's catch-ups split it, at the host's
// datagrams) give the same motion as over whole milliseconds, events
// (saturation, the integrator's limit) included.
TEST(ServoMotion, AnySplitOfTheTimeGivesTheSameMotion) {
  const MillAxis a = millAxis(0);
  auto run = [&](const std::vector<int>& splitUs) {
    machine::ServoAmplifier amplifier(a.amp);
    machine::Axis axis(a.p, 0.0);
    machine::ServoMotion motion;
    for (int ms = 0; ms < 1000; ++ms) {
      machine::ServoDrive drive{&amplifier, ms < 300 ? 10.0 : ms < 600 ? -3.0 : 0.5, true, a.p.inertia, 0.0};
      int done = 0;
      for (std::size_t i = 0; done < 1000; ++i) {
        const int us = std::min(splitUs[i % splitUs.size()], 1000 - done);
        motion.advance(axis, std::span(&drive, 1), false, std::chrono::microseconds(us));
        done += us;
      }
    }
    return std::pair{axis.position(), motion.events()};
  };
  const auto [whole, events] = run({1000});
  EXPECT_GE(events, 4U);
  for (const auto& split : std::vector<std::vector<int>>{{100}, {37, 263, 600}, {999, 1}, {3, 17, 250, 7}}) {
    const auto [position, unused] = run(split);
    // Events are found to a nanosecond: at 250 mm/s a few 1e-8 mm.
    EXPECT_NEAR(position, whole, 1e-7) << "spans of " << split[0] << " us, ...";
  }
}

// A push moves the axis whatever its drive does, at the push's speed, and
// lets go of it at rest; the drive's loop sees the push as an error. A
// jammed axis does not move at all, and its drive's loop winds up against
// it (its integrator at the peak torque) as a real drive's does.
TEST(ServoMotion, APushAndAJamOverrideTheDrive) {
  const MillAxis a = millAxis(0);
  machine::ServoAmplifier amplifier(a.amp);
  machine::Axis axis(a.p, 100.0);
  machine::ServoMotion motion;
  machine::ServoDrive off{&amplifier, 0.0, false, a.p.inertia, 0.0};
  axis.push(5.0, 50.0);  // 5 mm at 50 mm/s: 100 ms
  for (int ms = 0; ms < 50; ++ms) motion.advance(axis, std::span(&off, 1), false, 1ms);
  EXPECT_NEAR(axis.position(), 102.5, 1e-9);
  EXPECT_NEAR(axis.velocity(), 50.0, 1e-9);
  for (int ms = 0; ms < 60; ++ms) motion.advance(axis, std::span(&off, 1), false, 1ms);
  EXPECT_NEAR(axis.position(), 105.0, 1e-9);
  EXPECT_EQ(axis.velocity(), 0.0);
  EXPECT_FALSE(axis.pushing());

  machine::ServoDrive hold{&amplifier, 0.0, true, a.p.inertia, 0.0};
  axis.push(1.0, 50.0);
  for (int ms = 0; ms < 10; ++ms) motion.advance(axis, std::span(&hold, 1), false, 1ms);
  EXPECT_NEAR(axis.position(), 105.5, 1e-9);
  EXPECT_LT(amplifier.integral(), 0.0) << "it pushes back";

  axis.setJammed(true);
  const double jammedAt = axis.position();
  machine::ServoDrive drive{&amplifier, 5.0, true, a.p.inertia, 0.0};
  for (int ms = 0; ms < 500; ++ms) motion.advance(axis, std::span(&drive, 1), false, 1ms);
  EXPECT_EQ(axis.velocity(), 0.0);
  EXPECT_EQ(axis.position(), jammedAt);
  EXPECT_DOUBLE_EQ(amplifier.integral(), a.amp.peakTorque);
  EXPECT_DOUBLE_EQ(drive.torque, a.amp.peakTorque);
}

}  // namespace

namespace {

// A hard stop the axis is driven into stays its stop, to the bit, whatever
// the rounding of its position in motor revolutions (a 5 mm screw geared
// 3:1 and a stop at 182 mm do not divide exactly): the axis stops dead
// there, stays, and says so, and the spans cost no stream of events.
TEST(ServoMotion, AnAxisDrivenIntoAHardStopStaysAtIt) {
  const MillAxis a = millAxis(0);
  AxisParameters p = a.p;
  p.unitsPerMotorRev = 5.0 / 3.0;
  p.hardStopMax = 182.0;
  machine::ServoAmplifier amplifier(a.amp);
  machine::Axis axis(p, 180.0);
  machine::ServoMotion motion;
  machine::ServoDrive drive{&amplifier, 10.0, true, p.inertia, 0.0};
  for (int ms = 0; ms < 300; ++ms) {
    motion.advance(axis, std::span(&drive, 1), false, 1ms);
    ASSERT_LE(axis.position(), 182.0 + 1e-9) << "period " << ms;
  }
  EXPECT_TRUE(axis.atHardStop());
  EXPECT_EQ(axis.velocity(), 0.0);
  EXPECT_NEAR(axis.position(), 182.0, 1e-9);
  EXPECT_DOUBLE_EQ(drive.torque, a.amp.peakTorque) << "it pushes on, into the stop";
  EXPECT_LE(motion.events(), 10U);
}

// An axis at rest with its drives off, held by its brake, stays where it
// is without being solved; released, it is solved again and falls (the
// mill's Z: gravity beats friction). Put at a hard stop, it is at it.
TEST(ServoMotion, AnUnpoweredAxisAtRestStaysUntilItsBrakeLetsGo) {
  const MillAxis z = millAxis(2);
  machine::ServoAmplifier amplifier(z.amp);
  machine::Axis axis(z.p, -50.0);
  machine::ServoMotion motion;
  machine::ServoDrive off{&amplifier, 3.0, false, z.p.inertia, 0.0};
  for (int ms = 0; ms < 100; ++ms) motion.advance(axis, std::span(&off, 1), true, 1ms);
  EXPECT_EQ(axis.position(), -50.0 * (1.0 / z.p.unitsPerMotorRev) * z.p.unitsPerMotorRev);
  EXPECT_EQ(axis.velocity(), 0.0);
  EXPECT_EQ(off.torque, 0.0);
  EXPECT_EQ(amplifier.lastVelocityCommand(), 0.0);
  for (int ms = 0; ms < 100; ++ms) motion.advance(axis, std::span(&off, 1), false, 1ms);
  EXPECT_LT(axis.position(), -50.5) << "released, gravity pulls it down";

  machine::Axis atStop(z.p, z.p.hardStopMin);
  machine::ServoMotion still;
  for (int ms = 0; ms < 10; ++ms) still.advance(atStop, std::span(&off, 1), true, 1ms);
  EXPECT_TRUE(atStop.atHardStop());
  EXPECT_DOUBLE_EQ(atStop.position(), z.p.hardStopMin);
}

}  // namespace
