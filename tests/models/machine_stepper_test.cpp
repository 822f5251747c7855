// SPDX-License-Identifier: MIT
// A stepper axis on a HostMot2 StepGen: the mill with Z
// a stepper on StepGen 0 of the 7I92's 7I77+7I76 firmware, in process. The
// host writes the StepGen's rate register as LinuxCNC's hostmot2 does; the
// axis goes where the steps put it, and loses the steps that come faster
// than the motor's pull-out rate. Machine-file mistakes in the stepper keys
// name file, line, column and key.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "config/machine_toml.hpp"
#include "config/toml_reader.hpp"
#include "hostmot2/card.hpp"
#include "hostmot2/ioport.hpp"
#include "hostmot2/muxed_encoder.hpp"
#include "hostmot2/watchdog.hpp"
#include "machine/machine.hpp"
#include "support/machine_file_fixture.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace machine = lbpkit::model::machine;
namespace config = lbpkit::config;

namespace {

using namespace std::chrono_literals;
using hm2::SimTime;
using hm2::StepGen;

constexpr double kStepsPerMm = 800.0;  // 200 full steps x 8 microsteps / 2 mm pitch
constexpr std::size_t kZ = 2;

// The mill, Z a stepper (no brake: nothing releases it here).
machine::MachineDescription stepperMill(double maxStepRate = 0.0) {
  auto d = machine::mill();
  auto& z = d.axes[kZ];
  z.drives.clear();
  z.stepper = machine::StepperParameters{0, kStepsPerMm, maxStepRate};
  z.brakeOutput = -1;
  return d;
}

hm2::HostMot2Card::Options sevenI76Firmware() {
  hm2::HostMot2Card::Options o;
  o.pinout = hm2::cards::Pinout::SevenI77SevenI76;
  return o;
}

// The card, the machine behind it, and a host writing StepGen 0's registers.
struct Rig {
  hm2::HostMot2Card card{sevenI76Firmware()};
  machine::Machine m;
  SimTime t{};
  std::uint16_t base;

  explicit Rig(machine::MachineDescription d) : m(std::move(d), card), base(card.module<hm2::StepGen>()->descriptor().baseAddress) {
    // Step timing as hostmot2's stepgen writes it from steplen, stepspace,
    // dirsetup and dirhold (ns x ClockLow / 1e9): 1 us, 1 us, 10 us, 10 us.
    write(StepGen::kPulseWidth, 100);
    write(StepGen::kPulseIdle, 100);
    write(StepGen::kDirSetup, 1000);
    write(StepGen::kDirHold, 1000);
    write(StepGen::kMasterRate, 0xFFFFFFFFU);
  }
  void write(unsigned reg, std::uint32_t value) {
    // StepGen 0's register (instance 0 is at +0, as the single registers are).
    card.write32(static_cast<std::uint16_t>(base + reg * hm2::kRegisterStride), value, t);
  }
  // The rate register for `stepsPerSecond` (steps/s = rate x ClockLow / 2^32).
  void setStepRate(double stepsPerSecond) {
    const double rate = std::round(stepsPerSecond * 4294967296.0 / card.board().clockLow);
    write(StepGen::kRate, static_cast<std::uint32_t>(static_cast<std::int32_t>(rate)));
  }
  // `ms` servo periods as the sim runs them: the plant, then the card.
  void run(int ms) {
    for (int i = 0; i < ms; ++i) {
      t += 1ms;
      m.advance(t);
      card.advance(t);
    }
    // The plant catches up with the card's last period (it never runs the
    // StepGen ahead of the card).
    m.advance(t + 1us);
  }
  [[nodiscard]] std::int64_t steps() { return card.module<hm2::StepGen>()->steps(0, t); }
  [[nodiscard]] double z() const { return m.position(kZ); }
};

TEST(MachineStepper, ZMovesExactlyTheStepsOverStepsPerUnit) {
  Rig r(stepperMill());
  const double z0 = r.z();
  ASSERT_EQ(z0, -75.0);
  r.setStepRate(40'000.0);  // 50 mm/s
  r.run(100);
  const std::int64_t up = r.steps();
  // The StepGen's own rate: 4000 steps in 100 ms (the DDS may round one off).
  EXPECT_NEAR(static_cast<double>(up), 4000.0, 1.0);
  EXPECT_EQ(r.z(), z0 + static_cast<double>(up) / kStepsPerMm);
  EXPECT_GT(r.z(), z0 + 4.99);
  EXPECT_EQ(r.m.followingError(kZ), 0.0);
  const auto s = r.m.state();
  ASSERT_TRUE(s.axes[kZ].stepper.has_value());
  EXPECT_EQ(s.axes[kZ].stepper->steps, up);
  EXPECT_EQ(s.axes[kZ].stepper->lostSteps, 0);
  EXPECT_FALSE(s.axes[kZ].stepper->stalled);
  EXPECT_TRUE(s.axes[kZ].drives.empty());
  EXPECT_NEAR(s.axes[kZ].commandVelocity, 50.0, 0.01);
  EXPECT_EQ(s.axes[kZ].velocity, s.axes[kZ].commandVelocity);  // following the steps
  // The servo axes are untouched: X and Y stay where they were.
  EXPECT_EQ(s.axes[0].position, 200.0);
  EXPECT_EQ(s.axes[1].position, 150.0);
  EXPECT_FALSE(s.axes[0].stepper.has_value());
}

TEST(MachineStepper, ReversingBringsZBack) {
  Rig r(stepperMill());
  const double z0 = r.z();
  r.setStepRate(25'000.0);
  r.run(40);
  const std::int64_t out = r.steps();
  ASSERT_GT(out, 900);
  EXPECT_EQ(r.z(), z0 + static_cast<double>(out) / kStepsPerMm);
  r.setStepRate(-25'000.0);
  r.run(60);
  const std::int64_t net = r.steps();
  EXPECT_LT(net, 0);  // past where it started, the other way
  EXPECT_EQ(r.z(), z0 + static_cast<double>(net) / kStepsPerMm);
  EXPECT_LT(r.m.state().axes[kZ].velocity, 0.0);
  // Stopped: it stays.
  r.setStepRate(0.0);
  r.run(5);
  const std::int64_t rest = r.steps();
  r.run(20);
  EXPECT_EQ(r.steps(), rest);
  EXPECT_EQ(r.z(), z0 + static_cast<double>(rest) / kStepsPerMm);
  EXPECT_EQ(r.m.state().axes[kZ].velocity, 0.0);
}

// A motor wired the other way (reversed): each forward step moves Z down,
// what a configuration with a negative SCALE drives; the hard stop still
// ends it where the mechanics end.
TEST(MachineStepper, AReversedMotorMovesTheOtherWay) {
  auto d = stepperMill();
  d.axes[kZ].stepper->reversed = true;
  Rig r(std::move(d));
  const double z0 = r.z();
  r.setStepRate(40'000.0);
  r.run(100);
  const std::int64_t up = r.steps();
  ASSERT_GT(up, 3990);
  EXPECT_EQ(r.z(), z0 - static_cast<double>(up) / kStepsPerMm);
  EXPECT_NEAR(r.m.state().axes[kZ].commandVelocity, -50.0, 0.01);
  EXPECT_EQ(r.m.followingError(kZ), 0.0);
  // 75 mm down to the hard stop 5 mm under the travel (-150): 80 mm.
  r.run(1700);
  EXPECT_NEAR(r.z(), -155.0, 1.0 / kStepsPerMm);
  EXPECT_GT(r.m.state().axes[kZ].stepper->lostSteps, 0);
}

// A closed-loop stepper: an encoder on the motor's shaft (1000 lines, 4000
// counts a turn of the 5 mm screw: 800 counts a mm) counts where the steps
// put Z, on the card's muxed encoder 2.
TEST(MachineStepper, AClosedLoopSteppersEncoderCountsWhereItIs) {
  auto d = stepperMill();
  d.axes[kZ].stepper->encoderInput = 2;
  d.axes[kZ].stepper->encoder.linesPerRev = 1000;
  Rig r(std::move(d));
  const double z0 = r.z();
  const auto& encoders = r.card.part<hm2::MuxedEncoder>();
  const std::uint16_t before = encoders.count(2);
  r.setStepRate(40'000.0);
  r.run(100);
  // Stopped: the counter has caught up with the plant (which sees the
  // StepGen's steps one card period behind the card).
  r.setStepRate(0.0);
  r.run(5);
  const double moved = r.z() - z0;
  ASSERT_GT(moved, 4.99);
  const auto counted = static_cast<std::int16_t>(static_cast<std::uint16_t>(encoders.count(2) - before));
  EXPECT_NEAR(counted, moved * 800.0, 1.0);
}

// A switch on one of the card's own IO pins (LinuxCNC's gpio.NNN, as the
// 7I96S's inputs are wired): closed, it drives the pin high; open, low.
TEST(MachineStepper, ASwitchOnTheCardsOwnPinDrivesIt) {
  auto d = stepperMill();
  machine::SwitchParameters s;
  s.name = "z-low";
  s.daughtercard = machine::Daughtercard::Card;
  s.input = 30;  // port 1, bit 13: the 7I92's ports are 17 pins wide
  s.axis = "z";
  s.position = -70.0;
  s.tripAbove = true;
  d.switches.push_back(s);
  Rig r(std::move(d));
  const auto& io = r.card.part<hm2::IoPort>();
  ASSERT_EQ(io.width(), 17U);
  r.run(1);
  EXPECT_FALSE(io.pin(1, 13)) << "Z at -75 mm: open";
  r.setStepRate(40'000.0);  // up at 50 mm/s: past -70 in 100 ms
  r.run(150);
  EXPECT_GT(r.z(), -70.0);
  EXPECT_TRUE(io.pin(1, 13)) << "closed above -70 mm";
}

TEST(MachineStepper, StepsFasterThanThePullOutRateAreLost) {
  Rig below(stepperMill(20'000.0));
  // Just under the pull-out rate: every step followed, however the steps
  // fall into the plant's spans.
  below.setStepRate(19'900.0);
  below.run(200);
  EXPECT_EQ(below.m.state().axes[kZ].stepper->lostSteps, 0);
  EXPECT_EQ(below.z(), -75.0 + static_cast<double>(below.steps()) / kStepsPerMm);

  Rig r(stepperMill(20'000.0));
  const double z0 = r.z();
  r.setStepRate(30'000.0);
  r.run(100);
  const std::int64_t made = r.steps();
  EXPECT_NEAR(static_cast<double>(made), 3000.0, 1.0);
  auto s = r.m.state().axes[kZ];
  // Out of step: it stalls and stays stalled while the steps come that fast.
  EXPECT_TRUE(s.stepper->stalled);
  EXPECT_GT(s.stepper->lostSteps, made - 10);
  EXPECT_LT(r.z(), z0 + static_cast<double>(made) / kStepsPerMm - 3.0);  // the position lags the count
  EXPECT_NEAR(r.m.followingError(kZ), static_cast<double>(s.stepper->lostSteps) / kStepsPerMm, 1e-9);
  EXPECT_EQ(r.z(), z0 + static_cast<double>(made - s.stepper->lostSteps) / kStepsPerMm);
  // Slowed to what it follows: it steps again from where it stalled; the
  // lost steps stay lost (LinuxCNC never hears of them).
  const std::int64_t lost = s.stepper->lostSteps;
  r.setStepRate(10'000.0);
  r.run(50);
  s = r.m.state().axes[kZ];
  EXPECT_FALSE(s.stepper->stalled);
  EXPECT_EQ(s.stepper->lostSteps, lost);
  EXPECT_EQ(r.z(), z0 + static_cast<double>(r.steps() - lost) / kStepsPerMm);
  EXPECT_GT(r.steps(), made + 490);
}

TEST(MachineStepper, SwitchesTripWhereTheStepsPutZ) {
  Rig r(stepperMill());
  // Z's home switch closes from -5 mm up (the mill's cam); 70 mm away.
  const auto home = [&] {
    for (const auto& sw : r.m.state().switches)
      if (sw.name == "z-home") return sw.tripped;
    ADD_FAILURE() << "no z-home";
    return false;
  };
  EXPECT_FALSE(home());
  r.setStepRate(200'000.0);  // 250 mm/s
  r.run(270);                // 67.5 mm
  EXPECT_FALSE(home());
  r.run(20);  // 5 mm more
  EXPECT_TRUE(home());
  EXPECT_GT(r.z(), -5.0);
  // The hard stop (5 mm above the travel) stops it: the steps past it are lost.
  r.run(100);
  EXPECT_EQ(r.z(), 5.0);
  EXPECT_TRUE(r.m.state().axes[kZ].atHardStop);
  EXPECT_GT(r.m.state().axes[kZ].stepper->lostSteps, 0);
}

TEST(MachineStepper, JammedItLosesItsSteps) {
  Rig r(stepperMill());
  r.m.setJammed(kZ, true);
  r.setStepRate(40'000.0);
  r.run(10);
  EXPECT_EQ(r.z(), -75.0);
  EXPECT_EQ(r.m.state().axes[kZ].stepper->lostSteps, r.steps());
  EXPECT_THROW(r.m.push(kZ, 1.0, 10.0), std::invalid_argument);
}

// The HostMot2 watchdog bites (a host that stopped): every pin becomes an
// input, the StepGen's step pin with them
// (docs/protocol-facts.md#hostmot2-watchdog), and the drive sees no more
// steps though the StepGen runs on.
// Once the host writes the DDR again, the steps reach the drive again; the
// ones made meanwhile never did.
TEST(MachineStepper, AWatchdogBiteLeavesTheStepPinUndriven) {
  Rig r(stepperMill());
  const auto& wd = r.card.part<hm2::Watchdog>();
  const std::uint16_t timer = wd.descriptor().baseAddress;
  r.setStepRate(40'000.0);  // 50 mm/s
  r.run(10);
  const double z0 = r.z();
  EXPECT_GT(z0, -75.0 + 0.4);
  // 1 ms at ClockLow, armed by its first write; no pet comes.
  r.card.write32(timer, r.card.board().clockLow / 1000 - 1, r.t);
  r.run(20);
  ASSERT_TRUE(r.card.part<hm2::Watchdog>().bitten());
  EXPECT_FALSE(r.card.stepGenDriven(0));
  const double z1 = r.z();
  EXPECT_LT(z1, z0 + 2 * 50.0 * 0.001 + 1e-9) << "Z stops within the watchdog's millisecond";
  r.run(50);
  EXPECT_EQ(r.z(), z1) << "the StepGen steps on, the drive sees none";
  EXPECT_GT(r.steps(), 2000);
  // The host sets the step pin an output again (every pin, as hostmot2's
  // DDR write after a bite).
  for (std::uint16_t port = 0; port < r.card.board().ioPorts; ++port)
    r.card.write32(static_cast<std::uint16_t>(hm2::IoPort::kDdr + 4 * port), 0x1FFFF, r.t);
  EXPECT_TRUE(r.card.stepGenDriven(0));
  r.run(10);
  EXPECT_NEAR(r.z(), z1 + 0.5, 0.01) << "10 ms at 50 mm/s from where it stopped";
}

TEST(MachineStepper, TheCardMustHaveTheStepGen) {
  // The 7I92's default firmware (7I77x2) has no StepGen.
  hm2::HostMot2Card plain;
  try {
    machine::Machine m(stepperMill(), plain);
    ADD_FAILURE() << "a stepper on a card without StepGens";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("axis z is a stepper on StepGen 0, but the card's firmware"), std::string::npos)
        << e.what();
  }
  hm2::HostMot2Card card{sevenI76Firmware()};
  auto d = stepperMill();
  d.axes[kZ].stepper->stepGen = 5;
  try {
    machine::Machine m(d, card);
    ADD_FAILURE() << "StepGen 5 of 5";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), "machine: axis z: StepGen 5 is not on the card (its firmware has 5: 0..4)");
  }
}

// Machine files: a file of our own per test, removed afterwards.
class MachineStepperFile : public testing_config::MachineFileFixture {
 protected:
  MachineStepperFile() : MachineFileFixture("stepper.toml") {}
};

// Lines 1..4: a stepper axis with neither key that could go wrong yet.
const std::string kStepperZ = R"([[axis]]
name = "z"
travel = [-150.0, 0.0]
  [axis.stepper]
)";

TEST_F(MachineStepperFile, LoadsAndDrivesZ) {
  const auto d = config::loadMachine(write(kStepperZ + "  stepgen = 2\n  steps_per_unit = 800\n  max_step_rate = 50000\n"));
  ASSERT_EQ(d.axes.size(), 1U);
  EXPECT_TRUE(d.axes[0].drives.empty());
  ASSERT_TRUE(d.axes[0].stepper.has_value());
  EXPECT_TRUE(*d.axes[0].stepper == (machine::StepperParameters{2, 800.0, 50'000.0}));
  // From the motor and the screw: 200 x 16 / 5 mm = 640 steps per mm; no
  // pull-out rate: it follows every rate.
  const auto m = config::loadMachine(
      write("[[axis]]\nname = \"z\"\nscrew_pitch = 5.0\n  [axis.stepper]\n  stepgen = 0\n  microsteps = 16\n"));
  EXPECT_EQ(m.axes[0].stepper->stepsPerUnit, 640.0);
  EXPECT_EQ(m.axes[0].stepper->maxStepRate, 0.0);
  // And it runs: StepGen 2's steps move Z.
  hm2::HostMot2Card card{sevenI76Firmware()};
  machine::Machine machine(d, card);
  const std::uint16_t rate = card.module<hm2::StepGen>()->descriptor().baseAddress + 2 * 4;
  card.write32(rate, 0x00100000U, SimTime{});  // 2^20 x 1e8 / 2^32: 24414 steps/s
  card.advance(SimTime{10ms});
  machine.advance(SimTime{10ms});
  const auto steps = card.module<hm2::StepGen>()->steps(2, SimTime{10ms});
  EXPECT_NEAR(static_cast<double>(steps), 244.0, 1.0);
  EXPECT_EQ(machine.position(0), -75.0 + static_cast<double>(steps) / 800.0);
}

TEST_F(MachineStepperFile, EveryMistakeNamesTheKey) {
  struct Case {
    std::string text;
    std::string expected;  // after "FILE:"
  };
  const Case cases[] = {
      {kStepperZ + "  stepgen = 0\n  step_per_unit = 800\n",
       "6:19: axis[0].stepper.step_per_unit: unknown key; did you mean steps_per_unit?"},
      {kStepperZ + "  steps_per_unit = 800\n", "4:3: axis[0].stepper.stepgen: missing (this key is required)"},
      {kStepperZ + "  stepgen = 16\n  steps_per_unit = 800\n", "5:13: axis[0].stepper.stepgen: 16 is out of range: 0 to 15"},
      {kStepperZ + "  stepgen = \"0\"\n  steps_per_unit = 800\n",
       "5:13: axis[0].stepper.stepgen: expected an integer, not a string"},
      {kStepperZ + "  stepgen = 0\n",
       "4:3: axis[0].stepper.steps_per_unit: missing: the steps per mm (or the motor's full_steps and microsteps)"},
      {kStepperZ + "  stepgen = 0\n  steps_per_unit = 0\n",
       "6:20: axis[0].stepper.steps_per_unit: 0 is out of range: 0.001 to 1000000 steps per mm"},
      {kStepperZ + "  stepgen = 0\n  steps_per_unit = 800\n  microsteps = 8\n",
       "7:16: axis[0].stepper.microsteps: steps_per_unit is given: the motor's full_steps and microsteps are for "
       "working it out instead"},
      {kStepperZ + "  stepgen = 0\n  microsteps = 0\n", "6:16: axis[0].stepper.microsteps: 0 is out of range: 1 to 1000"},
      {kStepperZ + "  stepgen = 0\n  steps_per_unit = 800\n  max_step_rate = -5\n",
       "7:19: axis[0].stepper.max_step_rate: -5 is out of range: 1 to 10000000 steps/s"},
      {kStepperZ + "  stepgen = 0\n  steps_per_unit = 800\n[[axis]]\nname = \"x\"\n  [axis.stepper]\n  stepgen = 0\n"
                   "  steps_per_unit = 800\n",
       "10:13: axis[1].stepper.stepgen: StepGen 0 is already axis z's (at 5:13)"},
      {"[[axis]]\nname = \"z\"\n  [[axis.drive]]\n  analog_output = 0\n  [axis.stepper]\n  stepgen = 0\n"
       "  steps_per_unit = 800\n",
       "5:3: axis[0].stepper: an axis has servo drives ([[axis.drive]]) or a stepper ([axis.stepper]), not both"},
      {"[[axis]]\nname = \"z\"\nstepper = 0\n", "3:11: axis[0].stepper: expected a table ([stepper]), not an integer"},
  };
  for (const auto& c : cases) {
    const auto message = error(c.text);
    EXPECT_EQ(message, path_ + ":" + c.expected) << c.text;
  }
}

}  // namespace
