// SPDX-License-Identifier: MIT
// A machine wired to the 7I76 beside the 7I77: on the 7I92T's
// default firmware (7I77+7I76) a host runs the 7I76's field I/O processor
// on SSerial channel 3 through the host library, as LinuxCNC's hostmot2
// does, while the machine's switches, outputs, brake and spindle sit on the
// 7I76's terminals. Machine-file mistakes in that wiring name file, line,
// column and key.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "support/allocation_counter.hpp"
#include "config/machine_toml.hpp"
#include "config/toml_reader.hpp"
#include "hostmot2/card.hpp"
#include "lbpkit/sserial.hpp"
#include "machine/machine.hpp"
#include "support/machine_file_fixture.hpp"
#include "sim_card/sim_transport.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace machine = lbpkit::model::machine;
namespace remote = lbpkit::model::remote;
namespace config = lbpkit::config;

namespace {

using namespace std::chrono_literals;
using hm2::SimTime;
using hm2::StepGen;
using machine::Daughtercard;

constexpr unsigned kChannel = 3;  // PIN_7I77_7I76_34.vhd: the 7I76's field I/O
constexpr std::size_t kZ = 2;
constexpr double kStepsPerMm = 800.0;
constexpr unsigned kSpindleCounter = 6;  // the 7I76's encoder: muxed counter unit 3, counters 6 and 7
constexpr double kRpmPerVolt = 2400.0;

std::string examplePath(const std::string& name) { return std::string(LBPKIT_EXAMPLES_DIR) + "/machines/" + name; }

hm2::HostMot2Card::Options card7I92T() {
  hm2::HostMot2Card::Options o;
  o.card = hm2::cards::find("7I92T");  // its default firmware: 7I77+7I76
  return o;
}

// The mill with Z a stepper on StepGen 0 whose home and limits are on the
// 7I76's inputs 0..2 (home 5 mm above where Z starts), its brake released
// by the 7I76's output 3, a work light on the 7I76's output 4, and the
// spindle's VFD and encoder on the 7I76. The 7I77 keeps X and Y, their
// switches on its inputs 0..5, the E-stop and the probe.
machine::MachineDescription sevenI76Mill() {
  auto d = machine::mill();
  auto& z = d.axes[kZ];
  z.drives.clear();
  z.stepper = machine::StepperParameters{0, kStepsPerMm, 0.0};
  z.brakeOutput = 3;
  z.brakeDaughtercard = Daughtercard::SevenI76;
  for (auto& s : d.switches) {
    if (s.name == "z-home") s = {"z-home", machine::SwitchKind::Home, 0, machine::Contact::NormallyOpen, "z", -70.0,
                                 true, Daughtercard::SevenI76};
    if (s.name == "z-min") s.daughtercard = Daughtercard::SevenI76, s.input = 1;
    if (s.name == "z-max") s.daughtercard = Daughtercard::SevenI76, s.input = 2;
  }
  d.outputs = {{"coolant", 0, 480}, {"work-light", 4, 240, Daughtercard::SevenI76}};
  d.spindle->daughtercard = Daughtercard::SevenI76;
  d.spindle->vfd.rpmPerVolt = kRpmPerVolt;
  d.spindle->vfd.accelerationRpmPerSecond = 1e6;  // at speed within a few ms
  d.spindle->encoderDaughtercard = Daughtercard::SevenI76;
  d.spindle->encoderInput = 0;
  return d;
}

lbpkit::SmartSerial::Options only7I76() {
  lbpkit::SmartSerial::Options o;
  o.channelMask = 1U << kChannel;
  o.modes[kChannel] = 0;
  return o;
}

// The card, the host library running the 7I76's processor, and the machine.
struct SevenI76Machine : testing::Test {
  lbpkit::SimTransport t{card7I92T()};
  lbpkit::CardInfo info = lbpkit::readCardInfo(t);
  lbpkit::SmartSerial ss{t, info, only7I76()};
  remote::SevenI76FieldIo& board = *t.card().sevenI76();
  machine::Machine m{sevenI76Mill(), t.card(), SimTime{t.now()}};
  lbpkit::ElementRef input, output, spinout, spinena, spindir;

  void SetUp() override {
    ss.discover(1U << kChannel);
    ss.startNormal();
    input = ss.find(kChannel, "input");
    output = ss.find(kChannel, "output");
    spinout = ss.find(kChannel, "spinout");
    spinena = ss.find(kChannel, "spinena");
    spindir = ss.find(kChannel, "spindir");
    ASSERT_TRUE(input.valid() && output.valid() && spinout.valid() && spinena.valid() && spindir.valid());
  }
  // `n` servo periods as lbpkit sim runs them: the host's cycle, then the plant.
  void cycles(int n) {
    for (int i = 0; i < n; ++i) {
      ASSERT_TRUE(ss.cycle().ok);
      m.advance(SimTime{t.now() + 1ms});
      t.sleep(1ms);
    }
  }
  void writeStepGen(unsigned reg, std::uint32_t value) {
    const auto base = t.card().module<hm2::StepGen>()->descriptor().baseAddress;
    t.card().write32(static_cast<std::uint16_t>(base + reg * hm2::kRegisterStride), value, SimTime{t.now()});
  }
  // StepGen 0 stepping at `stepsPerSecond`, with hostmot2's timings.
  void stepZ(double stepsPerSecond) {
    writeStepGen(StepGen::kPulseWidth, 100);
    writeStepGen(StepGen::kPulseIdle, 100);
    writeStepGen(StepGen::kDirSetup, 1000);
    writeStepGen(StepGen::kDirHold, 1000);
    writeStepGen(StepGen::kMasterRate, 0xFFFFFFFFU);
    const double rate = std::round(stepsPerSecond * 4294967296.0 / t.card().board().clockLow);
    writeStepGen(StepGen::kRate, static_cast<std::uint32_t>(static_cast<std::int32_t>(rate)));
  }
  [[nodiscard]] const machine::Switches::State& sw(const std::string& name) const {
    static machine::Switches::State none;
    for (const auto& s : state_.switches)
      if (s.name == name) return s;
    ADD_FAILURE() << "no switch " << name;
    return none;
  }
  machine::Machine::State state_;
  void look() { state_ = m.state(); }
};

TEST_F(SevenI76Machine, ZMovingOntoItsHomeSwitchSetsThe7I76InputTheHostReads) {
  cycles(3);
  // Z at -75: home (NO, trips at -70 and above) open, the NC limits closed.
  EXPECT_FALSE(ss.bit(input, 0));
  EXPECT_TRUE(ss.bit(input, 1));
  EXPECT_TRUE(ss.bit(input, 2));
  EXPECT_EQ(board.inputs(), 0b110U);
  const std::uint32_t sevenI77Inputs = t.card().daughtercard(0).fieldIo.inputs();
  look();
  EXPECT_EQ(sw("z-home").daughtercard, Daughtercard::SevenI76);
  EXPECT_EQ(sw("x-home").daughtercard, Daughtercard::SevenI77);
  EXPECT_FALSE(sw("z-home").inputOn);

  ss.setBit(output, 3, true);  // Z's brake released
  stepZ(40'000.0);             // 50 mm/s up: 5 mm in 100 ms
  cycles(90);
  EXPECT_LT(m.position(kZ), -70.0);
  EXPECT_FALSE(ss.bit(input, 0));
  cycles(30);
  EXPECT_GE(m.position(kZ), -70.0);
  EXPECT_TRUE(ss.bit(input, 0)) << "Z at " << m.position(kZ);
  EXPECT_TRUE(board.input(0));
  look();
  EXPECT_TRUE(sw("z-home").tripped);
  EXPECT_TRUE(sw("z-home").inputOn);
  // The 7I77's inputs with the same numbers are other terminals: untouched.
  EXPECT_EQ(t.card().daughtercard(0).fieldIo.inputs(), sevenI77Inputs);

  // Tripped by hand too (a stuck switch), and released.
  stepZ(0.0);
  EXPECT_TRUE(m.setSwitch("z-max", true));  // NC: opens
  cycles(2);
  EXPECT_FALSE(ss.bit(input, 2));
  EXPECT_TRUE(m.setSwitch("z-max", false));
  cycles(2);
  EXPECT_TRUE(ss.bit(input, 2));
}

TEST_F(SevenI76Machine, TheBrakeHoldsUntilItsOutputOnThe7I76IsOn) {
  cycles(2);
  look();
  EXPECT_TRUE(state_.axes[kZ].brakeEngaged);
  stepZ(10'000.0);
  cycles(20);
  // Held: the StepGen steps, the motor does not follow.
  EXPECT_EQ(m.position(kZ), -75.0);
  EXPECT_GT(m.state().axes[kZ].stepper->lostSteps, 100);
  ss.setBit(output, 3, true);
  cycles(2);
  EXPECT_FALSE(m.state().axes[kZ].brakeEngaged);
  const double z = m.position(kZ);
  cycles(20);
  EXPECT_GT(m.position(kZ), z + 0.2);
  // Field power off at the 7I76: the coil drops out, the brake holds.
  board.setFieldVoltage(0.0, SimTime{t.now()});
  m.advance(SimTime{t.now() + 1ms});
  EXPECT_TRUE(m.state().axes[kZ].brakeEngaged);
}

TEST_F(SevenI76Machine, AnOutputOnThe7I76DrivesItsLoad) {
  cycles(2);
  look();
  ASSERT_EQ(state_.outputs.size(), 2U);
  EXPECT_EQ(state_.outputs[1].name, "work-light");
  EXPECT_EQ(state_.outputs[1].daughtercard, Daughtercard::SevenI76);
  EXPECT_FALSE(state_.outputs[1].on);
  EXPECT_EQ(board.outputCurrent(4), 0.0);
  EXPECT_EQ(board.outputLoad(4), 240.0);
  EXPECT_TRUE(std::isinf(board.outputLoad(5)));  // nothing wired there

  ss.setBit(output, 4, true);
  cycles(2);
  look();
  EXPECT_TRUE(state_.outputs[1].on);
  EXPECT_DOUBLE_EQ(board.outputCurrent(4), 24.0 / 240.0);  // sourcing: field power across the load
  EXPECT_DOUBLE_EQ(board.state().outputAmps[4], 24.0 / 240.0);
  // The 7I77's output 4 is another terminal; its coolant (output 0) is off.
  EXPECT_FALSE(t.card().daughtercard(0).fieldIo.outputOn(4));
  EXPECT_FALSE(state_.outputs[0].on);
  ss.setBit(output, 4, false);
  cycles(2);
  EXPECT_FALSE(m.state().outputs[1].on);
  EXPECT_EQ(board.outputCurrent(4), 0.0);
}

TEST_F(SevenI76Machine, TheSpindleTurnsAtSpinOutVoltsInTheDirectionSpinDirSays) {
  ss.set(spinout, 5.0);
  ss.setRaw(spinena, 1);
  ss.setRaw(spindir, 0);
  cycles(30);
  look();
  ASSERT_TRUE(state_.spindle.has_value());
  EXPECT_EQ(state_.spindle->daughtercard, Daughtercard::SevenI76);
  EXPECT_TRUE(state_.spindle->running);
  EXPECT_NEAR(board.spindleVolts(), 5.0, 10.0 / 65535);
  EXPECT_DOUBLE_EQ(state_.spindle->commandRpm, board.spindleVolts() * kRpmPerVolt);
  EXPECT_DOUBLE_EQ(state_.spindle->rpm, state_.spindle->commandRpm);
  EXPECT_NEAR(state_.spindle->rpm, 12'000.0, 1.0);
  // Its encoder is the 7I76's, on the card's muxed counter 6: counting up.
  // 256 lines: 1024 counts per revolution, about 1000 in 5 ms at 12000 rpm.
  // The counter is where the shaft was at the card's time, the plant's
  // revolutions at its own step's end: they agree within a step's counts
  // (50 us: 10 counts).
  const std::uint16_t c0 = t.card().part<hm2::MuxedEncoder>().count(kSpindleCounter);
  const double r0 = m.state().spindle->revolutions;
  cycles(5);
  const auto forward = static_cast<std::int16_t>(t.card().part<hm2::MuxedEncoder>().count(kSpindleCounter) - c0);
  EXPECT_GT(forward, 1000);
  EXPECT_NEAR(forward, (m.state().spindle->revolutions - r0) * 1024.0, 11.0);
  EXPECT_EQ(t.card().part<hm2::MuxedEncoder>().count(5), 0U);  // the 7I77's spindle encoder input: nothing there
  EXPECT_EQ(m.state().spindle->encoderCount, t.card().part<hm2::MuxedEncoder>().count(kSpindleCounter));

  // SpinDir on: the same speed in reverse.
  ss.setRaw(spindir, 1);
  cycles(30);
  look();
  EXPECT_DOUBLE_EQ(state_.spindle->commandRpm, -board.spindleVolts() * kRpmPerVolt);
  EXPECT_NEAR(state_.spindle->rpm, -12'000.0, 1.0);
  const std::uint16_t c1 = t.card().part<hm2::MuxedEncoder>().count(kSpindleCounter);
  const double r1 = m.state().spindle->revolutions;
  cycles(5);
  const auto backward = static_cast<std::int16_t>(t.card().part<hm2::MuxedEncoder>().count(kSpindleCounter) - c1);
  EXPECT_LT(backward, -1000);
  EXPECT_NEAR(backward, (m.state().spindle->revolutions - r1) * 1024.0, 11.0);

  // SpinEna off: the VFD ramps to a stop and stays there.
  ss.setRaw(spinena, 0);
  cycles(30);
  look();
  EXPECT_FALSE(state_.spindle->running);
  EXPECT_EQ(state_.spindle->commandRpm, 0.0);
  EXPECT_EQ(state_.spindle->rpm, 0.0);
  // And the speed follows SpinOut.
  ss.setRaw(spinena, 1);
  ss.setRaw(spindir, 0);
  ss.set(spinout, 10.0);
  cycles(40);
  EXPECT_NEAR(m.state().spindle->rpm, 24'000.0, 1e-6);
}

TEST_F(SevenI76Machine, TheHostGoingSilentStopsTheSpindle) {
  ss.set(spinout, 2.0);
  ss.setRaw(spinena, 1);
  cycles(30);
  ASSERT_NEAR(m.state().spindle->rpm, 4'800.0, 1.0);
  // No more cycles: the 7I76's watchdog turns SpinOut and SpinEna off. The
  // machine runs ahead of the card, as in cycles() and in the sim (its
  // encoders aim at the end of each plant span from where the card's
  // counters are: a card run far past the machine would run them on at the
  // last span's velocity).
  for (int i = 0; i < 200; ++i) {
    m.advance(SimTime{t.now() + 1ms});
    t.sleep(1ms);
    t.card().advance(SimTime{t.now()});
  }
  EXPECT_FALSE(board.spindleEnable());
  EXPECT_FALSE(m.state().spindle->running);
  EXPECT_EQ(m.state().spindle->rpm, 0.0);
}

TEST_F(SevenI76Machine, AdvancingDoesNotAllocate) {
  ss.set(spinout, 5.0);
  ss.setRaw(spinena, 1);
  ss.setBit(output, 3, true);
  ss.setBit(output, 4, true);
  stepZ(40'000.0);  // over the home switch within the run
  cycles(10);
  // The host's cycles (which do not allocate either: alloc_test.cpp) and
  // the plant's spans, the spindle turning, Z stepping onto its home switch.
  const auto before = testing_alloc::tAllocations;
  cycles(120);
  EXPECT_EQ(testing_alloc::tAllocations - before, 0U);
  EXPECT_GE(m.position(kZ), -70.0);  // the switch changed on the way
  EXPECT_TRUE(board.input(0));
}

// The trace: a stepper axis has no amplifier, so no <a>_enabled column;
// the servo axes have theirs.
TEST_F(SevenI76Machine, AStepperAxisHasNoEnabledColumnInTheTrace) {
  const auto columns = m.traceColumns();
  ASSERT_EQ(columns.size(), 1U + 6U + 6U + 5U + 1U);
  EXPECT_EQ(columns[6], "x_enabled");
  EXPECT_EQ(columns[12], "y_enabled");
  EXPECT_EQ(columns[13], "z_command_volts");
  EXPECT_EQ(columns[17], "z_following_error");
  EXPECT_EQ(columns[18], "spindle_rpm");
  std::vector<double> row(columns.size());
  m.traceRow(row);
  EXPECT_EQ(row[6], 0.0);  // ENA off
}

// The 7I76's processor runs from field power as the 7I77's does (their
// shared FieldPoweredProcessor): off below 8 V, a supply fault above 32 V.
TEST(SevenI76Power, ItRunsFromFieldPowerAsThe7I77sProcessorDoes) {
  remote::SevenI76FieldIo io;
  remote::FieldIoProcessor sibling;
  ASSERT_TRUE(io.powered());
  io.setInputVoltage(4, 24.0);
  EXPECT_TRUE(io.input(4));
  SimTime now{};
  for (double volts : {7.9, 8.0, 24.0, 33.0, 4.0, 24.0}) {
    now += 10ms;
    io.setFieldVoltage(volts, now);
    sibling.setFieldVoltage(volts, now);
    EXPECT_EQ(io.powered(), volts >= 8.0) << volts;
    EXPECT_EQ(io.powered(), sibling.powered()) << volts;
    EXPECT_EQ(io.faults(), sibling.faults()) << volts;
    EXPECT_EQ(io.fieldVoltage(), volts);
    if (volts > 32.0) {
      EXPECT_NE(io.faults() & remote::fault::kHighVoltage, 0);
    }
  }
  EXPECT_EQ(io.faults() & remote::fault::kHighVoltage, 0);  // booted again at 24 V
  // The input's 24 V against the thresholds of field power now (24 V): on.
  EXPECT_TRUE(io.input(4));
  io.setFieldVoltage(60.0, SimTime{100'000'000});  // 24 V is below 40 % of 60 V: off
  EXPECT_FALSE(io.input(4));
  io.powerCycle(SimTime{200'000'000});
  EXPECT_TRUE(io.powered());
}

TEST(SevenI76MachineWiring, A7I76WiringNeedsAFirmwareWithA7I76) {
  hm2::HostMot2Card plain;  // the 7I92's default firmware, 7I77x2: no 7I76
  auto d = machine::mill();
  d.switches[0].daughtercard = Daughtercard::SevenI76;
  try {
    machine::Machine m(d, plain);
    ADD_FAILURE() << "a 7I76 switch on a card without a 7I76";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "machine: the 7I76 is not on the card: its firmware (7I77x2) has none (switch x-home is on its field "
              "input 0); the 7I77+7I76 firmwares have one: the 7I92's pinout \"7I77+7I76\", the 7I92T's default");
  }
  // The spindle alone on it: the same.
  auto s = machine::mill();
  s.spindle->daughtercard = Daughtercard::SevenI76;
  EXPECT_THROW({ machine::Machine m(s, plain); }, std::invalid_argument);
  // The 7I76's one encoder input is 0.
  hm2::HostMot2Card t(card7I92T());
  auto e = sevenI76Mill();
  e.spindle->encoderInput = 1;
  EXPECT_THROW({ machine::Machine m(e, t); }, std::invalid_argument);
}

// Machine files.
class SevenI76MachineFile : public testing_config::MachineFileFixture {
 protected:
  SevenI76MachineFile() : MachineFileFixture("machine-7i76.toml") {}
};

TEST_F(SevenI76MachineFile, TheExampleLoadsAndRunsOnThe7I92T) {
  const auto d = config::loadMachine(examplePath("mill-7i76.toml"));
  EXPECT_EQ(d.name, "mill-7i76");
  EXPECT_NE(d.sevenI76Where.find("mill-7i76.toml:"), std::string::npos);
  ASSERT_TRUE(d.spindle.has_value());
  EXPECT_EQ(d.spindle->daughtercard, Daughtercard::SevenI76);
  EXPECT_EQ(d.spindle->encoderDaughtercard, Daughtercard::SevenI76);
  EXPECT_EQ(d.spindle->encoderInput, 0U);
  ASSERT_TRUE(d.axes[kZ].stepper.has_value());
  EXPECT_EQ(d.axes[kZ].stepper->stepsPerUnit, 320.0);
  unsigned on76 = 0;
  for (const auto& s : d.switches)
    if (s.daughtercard == Daughtercard::SevenI76) {
      ++on76;
      EXPECT_EQ(s.axis, "z") << s.name;
    }
  EXPECT_EQ(on76, 3U);

  hm2::HostMot2Card card(card7I92T());
  machine::Machine m(d, card);
  card.advance(SimTime{1ms});
  m.advance(SimTime{1ms});
  // Z's NC limits closed on the 7I76 (field power), home open; X's and Y's
  // on the 7I77 likewise.
  EXPECT_EQ(card.sevenI76()->inputs(), 0b110U);
  EXPECT_EQ(card.daughtercard(0).fieldIo.inputs() & 0x3FU, 0b110110U);
  EXPECT_EQ(card.sevenI76()->outputLoad(0), 960.0);
  EXPECT_EQ(card.sevenI76()->outputLoad(1), 240.0);

  // On the 7I92's default firmware it is refused, naming the first key that
  // wires the 7I76 (Z's brake's board).
  hm2::HostMot2Card plain;
  try {
    machine::Machine refused(d, plain);
    ADD_FAILURE() << "mill-7i76 on a card without a 7I76";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(examplePath("mill-7i76.toml") + ":", 0), 0U) << what;
    EXPECT_NE(what.find(": axis[2].brake_daughtercard: the 7I76 is not on the card: its firmware (7I77x2) has none "
                        "(axis z's brake is on its field output 1)"),
              std::string::npos)
        << what;
  }
}

TEST_F(SevenI76MachineFile, TheSameNumberOnEachBoardIsTwoTerminals) {
  const auto& path = write(R"(
[[switch]]
name = "a"
input = 3
[[switch]]
name = "b"
daughtercard = "7I76"
input = 3
[[output]]
name = "lamp"
output = 15
[[output]]
name = "horn"
daughtercard = "7I76"
output = 15
)");
  const auto d = config::loadMachine(path);
  ASSERT_EQ(d.switches.size(), 2U);
  EXPECT_EQ(d.switches[0].daughtercard, Daughtercard::SevenI77);
  EXPECT_EQ(d.switches[1].daughtercard, Daughtercard::SevenI76);
  EXPECT_EQ(d.outputs[1].daughtercard, Daughtercard::SevenI76);
  EXPECT_EQ(d.sevenI76Where, path + ":7:16: switch[1].daughtercard");
  // Both inputs 3 are driven, each on its own board.
  hm2::HostMot2Card card(card7I92T());
  machine::Machine m(d, card);
  m.setSwitch("b", true);
  EXPECT_TRUE(card.sevenI76()->input(3));
  EXPECT_FALSE(card.daughtercard(0).fieldIo.input(3));
  m.setSwitch("a", true);
  EXPECT_TRUE(card.daughtercard(0).fieldIo.input(3));
  // Without a 7I76: refused at the key that first wires it.
  hm2::HostMot2Card plain;
  try {
    machine::Machine refused(d, plain);
    ADD_FAILURE() << "no 7I76";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              path + ":7:16: switch[1].daughtercard: the 7I76 is not on the card: its firmware (7I77x2) has none "
                     "(switch b is on its field input 3); the 7I77+7I76 firmwares have one: the 7I92's pinout "
                     "\"7I77+7I76\", the 7I92T's default");
  }
}

TEST_F(SevenI76MachineFile, EveryMistakeNamesFileLineColumnAndKey) {
  struct Case {
    std::string text;
    std::string expected;  // after "FILE:"
  };
  const std::string zAxis = "[[axis]]\nname = \"z\"\ntravel = [-150.0, 0.0]\n  [axis.stepper]\n  stepgen = 0\n"
                            "  steps_per_unit = 800\n";
  const Case cases[] = {
      {"[[switch]]\nname = \"a\"\ndaughtercard = \"7I75\"\ninput = 0\n",
       "3:16: switch[0].daughtercard: \"7I75\" is not one of \"7I77\", \"7I76\", \"card\""},
      {"[[switch]]\nname = \"a\"\ndaughtercard = 76\ninput = 0\n",
       "3:16: switch[0].daughtercard: expected a string (\"7I77\", \"7I76\", \"card\"), not an integer"},
      {"[[switch]]\nname = \"a\"\ndaughtercard = \"7I76\"\ninput = 32\n",
       "4:9: switch[0].input: 32 is out of range: 0 to 31"},
      {"[[switch]]\nname = \"a\"\ndaughtercard = \"7I76\"\ninput = -1\n",
       "4:9: switch[0].input: -1 is out of range: 0 to 31"},
      {"[[output]]\nname = \"lamp\"\ndaughtercard = \"7I76\"\noutput = 16\n",
       "4:10: output[0].output: 16 is out of range: 0 to 15"},
      {"[[switch]]\nname = \"a\"\ndaughtercard = \"7I76\"\ninput = 5\n[[switch]]\nname = \"b\"\ndaughtercard = "
       "\"7I76\"\ninput = 5\n",
       "8:9: switch[1].input: the 7I76's field input 5 is already switch a's (at 4:9)"},
      {"[[output]]\nname = \"a\"\ndaughtercard = \"7I76\"\noutput = 2\n[[output]]\nname = \"b\"\ndaughtercard = "
       "\"7I76\"\noutput = 2\n",
       "8:10: output[1].output: the 7I76's field output 2 is already output a's (at 4:10)"},
      {"[spindle]\ndaughtercard = \"7I76\"\nanalog_output = 5\n",
       "3:17: spindle.analog_output: the spindle is on the 7I76 (daughtercard = \"7I76\"): its speed, run and "
       "direction are the 7I76's SpinOut, SpinEna and SpinDir; analog_output and enable are the 7I77's"},
      {"[spindle]\ndaughtercard = \"7I76\"\nenable = 5\n",
       "3:10: spindle.enable: the spindle is on the 7I76 (daughtercard = \"7I76\"): its speed, run and direction are "
       "the 7I76's SpinOut, SpinEna and SpinDir; analog_output and enable are the 7I77's"},
      {"[spindle]\ndaughtercard = \"7I76\"\nencoder_input = 3\n",
       "3:17: spindle.encoder_input: the 7I76 has one encoder input, its spindle encoder: 0 (the card's muxed "
       "counter 6), or -1 for none; the 7I77's 0..5 need encoder_daughtercard = \"7I77\", not 3"},
      {"[spindle]\nencoder_daughtercard = \"7I67\"\n",
       "2:24: spindle.encoder_daughtercard: \"7I67\" is not one of \"7I77\", \"7I76\""},
      {zAxis.substr(0, zAxis.find("  [axis")) + "brake_output = 16\nbrake_daughtercard = \"7I76\"\n",
       "4:16: axis[0].brake_output: 16 is out of range: -1 to 15"},
      {zAxis.substr(0, zAxis.find("  [axis")) + "brake_output = 2\nbrake_daughtercard = \"7i76\"\n",
       "5:22: axis[0].brake_daughtercard: \"7i76\" is not one of \"7I77\", \"7I76\""},
      {"[[output]]\nname = \"a\"\noutput = 2\ndaughter_card = \"7I76\"\n",
       "4:17: output[0].daughter_card: unknown key; did you mean daughtercard?"},
  };
  for (const auto& c : cases) {
    const auto message = error(c.text);
    EXPECT_EQ(message, path_ + ":" + c.expected) << c.text;
  }
}

TEST_F(SevenI76MachineFile, TheSpindleOnThe7I76FreesAout5AndTakesTheDefaults) {
  const auto& path = write(R"(
[[axis]]
name = "x"
  [[axis.drive]]
  analog_output = 5
  encoder_input = 4
[spindle]
daughtercard = "7I76"
)");
  const auto d = config::loadMachine(path);
  ASSERT_TRUE(d.spindle.has_value());
  EXPECT_EQ(d.spindle->daughtercard, Daughtercard::SevenI76);
  EXPECT_EQ(d.spindle->encoderDaughtercard, Daughtercard::SevenI76);
  EXPECT_EQ(d.spindle->encoderInput, 0U);  // the 7I76's one encoder input
  EXPECT_EQ(d.sevenI76Where, path + ":8:16: spindle.daughtercard");
  // The VFD on the 7I76 and its encoder on the 7I77's 5, or none.
  write("[spindle]\ndaughtercard = \"7I76\"\nencoder_daughtercard = \"7I77\"\n");
  EXPECT_EQ(config::loadMachine(path_).spindle->encoderInput, 5U);
  write("[spindle]\ndaughtercard = \"7I76\"\nencoder_input = -1\n");
  EXPECT_FALSE(config::loadMachine(path_).spindle->encoderInput.has_value());
  // A brake on the 7I76 is noted where it is; one with no brake output is no wiring.
  write("[[axis]]\nname = \"z\"\nbrake_daughtercard = \"7I76\"\n  [axis.stepper]\n  stepgen = 0\n"
        "  steps_per_unit = 800\n");
  EXPECT_EQ(config::loadMachine(path_).sevenI76Where, "");
  write("[[axis]]\nname = \"z\"\nbrake_output = 1\nbrake_daughtercard = \"7I76\"\n  [axis.stepper]\n"
        "  stepgen = 0\n  steps_per_unit = 800\n");
  const auto z = config::loadMachine(path_);
  EXPECT_EQ(z.axes[0].brakeDaughtercard, Daughtercard::SevenI76);
  EXPECT_EQ(z.sevenI76Where, path_ + ":4:22: axis[0].brake_daughtercard");
}

}  // namespace
