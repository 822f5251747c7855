// SPDX-License-Identifier: MIT
// Machine files: examples/machines/*.toml load to exactly
// the built-ins, a file with a few keys takes the documented defaults, and
// every mistake is an error naming file, line, column and key.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "config/card_toml.hpp"
#include "config/machine_toml.hpp"
#include "config/toml_reader.hpp"
#include "machine/machine_file.hpp"
#include "support/machine_file_fixture.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace machine = lbpkit::model::machine;
namespace remote = lbpkit::model::remote;
namespace lbp = lbpkit::model::lbp;
namespace config = lbpkit::config;

namespace {

using machine::MachineDescription;

std::string examplePath(const std::string& name) { return std::string(LBPKIT_EXAMPLES_DIR) + "/machines/" + name; }

// A file of our own per test, removed afterwards.
class MachineFile : public testing_config::MachineFileFixture {};

// Field by field, so that a difference says where it is.
void expectSame(const MachineDescription& loaded, const MachineDescription& builtin) {
  EXPECT_EQ(loaded.name, builtin.name);
  EXPECT_EQ(loaded.step.count(), builtin.step.count());
  ASSERT_EQ(loaded.axes.size(), builtin.axes.size());
  for (std::size_t i = 0; i < loaded.axes.size(); ++i) {
    const auto& a = loaded.axes[i];
    const auto& b = builtin.axes[i];
    EXPECT_EQ(a.name, b.name) << "axis " << i;
    ASSERT_EQ(a.drives.size(), b.drives.size()) << "axis " << b.name;
    for (std::size_t d = 0; d < a.drives.size(); ++d) {
      EXPECT_TRUE(a.drives[d].amplifier == b.drives[d].amplifier) << "axis " << b.name << " drive " << d;
      EXPECT_TRUE(a.drives[d].encoder == b.drives[d].encoder) << "axis " << b.name << " drive " << d;
      EXPECT_TRUE(a.drives[d] == b.drives[d]) << "axis " << b.name << " drive " << d;
    }
    EXPECT_EQ(a.travelMin, b.travelMin) << b.name;
    EXPECT_EQ(a.travelMax, b.travelMax) << b.name;
    EXPECT_EQ(a.initialPosition, b.initialPosition) << b.name;
    EXPECT_EQ(a.massKg, b.massKg) << b.name;
    EXPECT_EQ(a.brakeOutput, b.brakeOutput) << b.name;
    EXPECT_TRUE(a == b) << "axis " << b.name;
  }
  ASSERT_EQ(loaded.spindle.has_value(), builtin.spindle.has_value());
  if (builtin.spindle) {
    EXPECT_TRUE(loaded.spindle->vfd == builtin.spindle->vfd);
    EXPECT_TRUE(loaded.spindle->encoder == builtin.spindle->encoder);
    EXPECT_TRUE(*loaded.spindle == *builtin.spindle);
  }
  ASSERT_EQ(loaded.switches.size(), builtin.switches.size());
  for (std::size_t i = 0; i < loaded.switches.size(); ++i)
    EXPECT_TRUE(loaded.switches[i] == builtin.switches[i]) << "switch " << builtin.switches[i].name;
  ASSERT_EQ(loaded.outputs.size(), builtin.outputs.size());
  for (std::size_t i = 0; i < loaded.outputs.size(); ++i)
    EXPECT_TRUE(loaded.outputs[i] == builtin.outputs[i]) << "output " << builtin.outputs[i].name;
  EXPECT_TRUE(loaded == builtin);
}

TEST_F(MachineFile, ExamplesAreTheBuiltIns) {
  expectSame(config::loadMachine(examplePath("mill.toml")), machine::mill());
  expectSame(config::loadMachine(examplePath("lathe.toml")), machine::lathe());
  expectSame(config::loadMachine(examplePath("gantry.toml")), machine::gantry());
  // The names are the built-ins themselves, not files.
  EXPECT_TRUE(config::loadMachine("mill") == machine::mill());
  EXPECT_TRUE(config::loadMachine("lathe") == machine::lathe());
  EXPECT_TRUE(config::loadMachine("gantry") == machine::gantry());
  // The built-ins differ from each other (the comparison can fail).
  EXPECT_FALSE(machine::mill() == machine::gantry());
}

// `reversed`: the motor turns the other way for a positive input, what a
// configuration with a negative OUTPUT_SCALE drives; off by default.
TEST_F(MachineFile, AReversedDriveCommandsTheOtherWay) {
  const auto d = config::loadMachine(write(R"(
[[axis]]
name = "x"
  [[axis.drive]]
  analog_output = 0
  [axis.drive.amplifier]
  gain = 4.0
  reversed = true
[[axis]]
name = "y"
  [[axis.drive]]
  analog_output = 1
)"));
  ASSERT_TRUE(d.axes[0].drives[0].amplifier.reversed);
  EXPECT_FALSE(d.axes[1].drives[0].amplifier.reversed);
  EXPECT_EQ(machine::ServoAmplifier(d.axes[0].drives[0].amplifier).command(2.0), -8.0);
  EXPECT_EQ(machine::ServoAmplifier(d.axes[1].drives[0].amplifier).command(2.0), 10.0);
  EXPECT_NE(error("[[axis]]\nname = \"x\"\n  [[axis.drive]]\n  analog_output = 0\n  [axis.drive.amplifier]\n"
                  "  reversed = 1\n"),
            "");
}

TEST_F(MachineFile, AFewKeysTakeTheDocumentedDefaults) {
  const auto& path = write(R"(
[[axis]]
name = "x"
  [[axis.drive]]
  analog_output = 3

[spindle]

[[switch]]
name = "x-min"
kind = "min_limit"
input = 7
axis = "x"
position = -1.0

[[switch]]
name = "button"
input = 8

[[output]]
name = "lamp"
output = 4
)",
                           "few.toml");
  const auto m = config::loadMachine(path);
  EXPECT_EQ(m.name, std::filesystem::path(path).stem().string());  // the file's name
  EXPECT_EQ(m.step, lbp::SimTime{1'000'000});
  ASSERT_EQ(m.axes.size(), 1U);
  machine::AxisDescription a;  // the defaults, but for what the file says
  a.name = "x";
  a.initialPosition = 50.0;  // the middle of the default travel [0, 100]
  machine::DriveDescription d;
  d.analogOutput = 3;
  d.enable = 3;        // the analog output's number
  d.encoderInput = 3;  // likewise
  a.drives = {d};
  EXPECT_TRUE(m.axes[0] == a);
  EXPECT_EQ(m.axes[0].travelMax, 100.0);
  EXPECT_EQ(m.axes[0].drives[0].encoder.linesPerRev, 2000U);
  ASSERT_TRUE(m.spindle.has_value());
  EXPECT_TRUE(*m.spindle == machine::SpindleDescription{});
  EXPECT_EQ(m.spindle->encoderInput, 5U);
  ASSERT_EQ(m.switches.size(), 2U);
  EXPECT_EQ(m.switches[0].contact, machine::Contact::NormallyClosed);  // a limit
  EXPECT_FALSE(m.switches[0].tripAbove);                                // a min limit
  EXPECT_TRUE(m.switches[1] == (machine::SwitchParameters{"button", machine::SwitchKind::Other, 8,
                                                          machine::Contact::NormallyOpen, "", 0.0, true}));
  ASSERT_EQ(m.outputs.size(), 1U);
  EXPECT_EQ(m.outputs[0].loadOhms, 480.0);
  // -1: no spindle encoder; no [spindle]: no spindle.
  EXPECT_FALSE(config::loadMachine(write("[spindle]\nencoder_input = -1\n")).spindle->encoderInput.has_value());
  EXPECT_FALSE(config::loadMachine(write("[[output]]\nname = \"lamp\"\noutput = 4\n")).spindle.has_value());
  // A file with nothing in it is no machine.
  for (const char* empty : {"", "name = \"empty\"\n", "# only a comment\n"})
    EXPECT_THROW((void)config::loadMachine(write(empty)), std::exception) << "\"" << empty << "\"";
}

// The smallest machine the mistakes below are made in (lines 1..8).
const std::string kAxisX = R"([[axis]]
name = "x"
travel = [0.0, 400.0]
  [[axis.drive]]
  analog_output = 0
[[switch]]
name = "x-home"
input = 0
)";

TEST_F(MachineFile, EveryMistakeNamesFileLineColumnAndKey) {
  struct Case {
    std::string text;
    std::string expected;  // after "FILE:"
  };
  const Case cases[] = {
      // A misspelt key, with the nearest known one; and one far from any. (The
      // column is the value's, as for every other mistake.)
      {"[[axis]]\nname = \"x\"\nscew_pitch = 5.0\n", "3:14: axis[0].scew_pitch: unknown key; did you mean screw_pitch?"},
      {"nmae = \"mill\"\n", "1:8: nmae: unknown key; did you mean name?"},
      {kAxisX + "colour = \"red\"\n",
       "9:10: switch[0].colour: unknown key (known here: name, kind, input, contact, axis, position, trip_above, "
       "daughtercard)"},
      // Wrong types.
      {"[[axis]]\nname = \"x\"\nmass_kg = \"heavy\"\n", "3:11: axis[0].mass_kg: expected a number (kg), not a string"},
      {kAxisX + "kind = 3\n", "9:8: switch[0].kind: expected a string (\"home\", \"min_limit\", \"max_limit\", "
                              "\"estop\", \"probe\", \"other\"), not an integer"},
      {"[[axis]]\nname = \"x\"\n  [[axis.drive]]\n  analog_output = 1.0\n",
       "4:19: axis[0].drive[0].analog_output: expected an integer, not a number"},
      {"[[axis]]\nname = \"x\"\nvertical = \"yes\"\n", "3:12: axis[0].vertical: expected true or false, not a string"},
      {"axis = 3\n", "1:8: axis: expected an array of tables ([[axis]]), not an integer"},
      {"[axis]\nname = \"x\"\n", "1:1: axis: expected an array of tables ([[axis]]), not a table"},
      {"[[axis]]\nname = \"x y\"\n", "2:8: axis[0].name: \"x y\" is not a name: 1 to 40 letters, digits, '_' or '-'"},
      // A NUL shows, and the message goes on past it.
      {"[[axis]]\nname = \"x\\u0000y\"\n",
       "2:8: axis[0].name: \"x\\x00y\" is not a name: 1 to 40 letters, digits, '_' or '-'"},
      // Out of range.
      {"[[axis]]\nname = \"x\"\n  [[axis.drive]]\n  analog_output = 0\n  encoder_input = 6\n",
       "5:19: axis[0].drive[0].encoder_input: 6 is out of range: 0 to 5"},
      {"[[axis]]\nname = \"x\"\n  [[axis.drive]]\n  analog_output = 6\n",
       "4:19: axis[0].drive[0].analog_output: 6 is out of range: 0 to 5"},
      {"[[axis]]\nname = \"x\"\nmass_kg = 0\n", "3:11: axis[0].mass_kg: 0 is out of range: 0.001 to 100000 kg"},
      {"[[axis]]\nname = \"x\"\nscrew_pitch = -5.0\n",
       "3:15: axis[0].screw_pitch: -5 is out of range: 0.01 to 10000 mm"},
      {"[[axis]]\nname = \"x\"\nscrew_pitch = 1e-308\n", "3:15: axis[0].screw_pitch: 1e-308 is out of range: 0.01 to 10000 mm"},
      {"[[axis]]\nname = \"x\"\ntravel = [10.0, 5.0]\n",
       "3:10: axis[0].travel: [10, 5]: the low end must be below the high end"},
      {"[[axis]]\nname = \"x\"\ntravel = [0.0]\n", "3:10: axis[0].travel: expected [low, high] (mm), not 1 values"},
      {"[[axis]]\nname = \"x\"\ntravel = [0.0, 400.0]\ninitial_position = 410.0\n",
       "4:20: axis[0].initial_position: 410 mm is past the hard stops (-5 to 405 mm: the travel and the overtravel)"},
      {"[[axis]]\nname = \"x\"\nbrake_output = 16\n", "3:16: axis[0].brake_output: 16 is out of range: -1 to 15"},
      {kAxisX + "[[switch]]\nname = \"x-max\"\ninput = 32\n", "11:9: switch[1].input: 32 is out of range: 0 to 31"},
      {"[[output]]\nname = \"lamp\"\noutput = 16\n", "3:10: output[0].output: 16 is out of range: 0 to 15"},
      {"step_us = 0\n", "1:11: step_us: 0 is out of range: 1 to 1000 us"},
      {"[[axis]]\nname = \"x\"\n  [[axis.drive]]\n  analog_output = 0\n  [axis.drive.amplifier]\n  bandwidth_hz = 0\n",
       "6:18: axis[0].drive[0].amplifier.bandwidth_hz: 0 is out of range: 0.1 to 100000 Hz"},
      {"[[axis]]\nname = \"x\"\n  [[axis.drive]]\n  analog_output = 0\n  [axis.drive.amplifier]\n  mode = \"current\"\n",
       "6:10: axis[0].drive[0].amplifier.mode: \"current\" is not one of \"velocity\", \"torque\""},
      // Cross-references: an axis the machine lacks, things used twice.
      {kAxisX + "axis = \"w\"\nposition = 1.0\n", "9:8: switch[0].axis: the machine has no axis \"w\" (its axes: x)"},
      {kAxisX + "[[switch]]\nname = \"x-max\"\ninput = 0\n",
       "11:9: switch[1].input: field input 0 is already switch x-home's (at 8:9)"},
      {kAxisX + "[[switch]]\nname = \"x-home\"\ninput = 1\n", "10:8: switch[1].name: \"x-home\" is already switch[0]'s name"},
      // x's encoder 0 is its default (the analog output's number): pointed at
      // x's [[axis.drive]].
      {"[[axis]]\nname = \"x\"\n  [[axis.drive]]\n  analog_output = 0\n[[axis]]\nname = \"y\"\n  [[axis.drive]]\n"
       "  analog_output = 1\n  encoder_input = 0\n",
       "9:19: axis[1].drive[0].encoder_input: encoder 0 is already axis x's (at 3:3)"},
      {"[[axis]]\nname = \"x\"\n  [[axis.drive]]\n  analog_output = 0\n[[axis]]\nname = \"x\"\n  [[axis.drive]]\n"
       "  analog_output = 1\n",
       "6:8: axis[1].name: \"x\" is already axis[0]'s name"},
      // A default that clashes points at the table it was left out of.
      {"[[axis]]\nname = \"x\"\n  [[axis.drive]]\n  analog_output = 5\n\n[spindle]\nmax_rpm = 3000\n",
       "6:1: spindle.analog_output: analog output 5 is already axis x's (at 4:19)"},
      {"[[output]]\nname = \"a\"\noutput = 3\n[[output]]\nname = \"b\"\noutput = 3\n",
       "6:10: output[1].output: field output 3 is already output a's (at 3:10)"},
      // Switches that could not work as written.
      {kAxisX + "kind = \"home\"\n", "6:1: switch[0].axis: missing: a home switch is on an axis"},
      {kAxisX + "axis = \"x\"\n", "6:1: switch[0].position: missing (this key is required)"},
      {kAxisX + "kind = \"min_limit\"\naxis = \"x\"\nposition = 10.0\n",
       "11:12: switch[0].position: 10 mm is inside axis x's travel (0 to 400 mm): a min limit trips at or below "
       "the travel"},
      {kAxisX + "kind = \"max_limit\"\naxis = \"x\"\nposition = 410.0\n",
       "11:12: switch[0].position: 410 mm is past axis x's hard stops (-5 to 405 mm): the switch would never trip"},
      {kAxisX + "kind = \"max_limit\"\naxis = \"x\"\nposition = 402.0\ntrip_above = false\n",
       "12:14: switch[0].trip_above: a max limit trips at or above its position"},
      {kAxisX + "position = 3.0\n",
       "9:12: switch[0].position: only a switch on an axis trips at a position (this one trips when told: E-stop "
       "button, probe)"},
      // Required keys, and an axis with no motor.
      {"[[switch]]\nname = \"estop\"\n", "1:1: switch[0].input: missing (this key is required)"},
      {"[[axis]]\nname = \"x\"\n", "1:1: axis[0].drive: missing: an axis needs at least one motor ([[axis.drive]])"},
      {"[[axis]]\nname = \"spindle\"\n", "2:8: axis[0].name: \"spindle\" is the spindle's name, not an axis'"},
  };
  for (const auto& c : cases) {
    const auto message = error(c.text);
    EXPECT_EQ(message, path_ + ":" + c.expected) << c.text;
  }
}

TEST_F(MachineFile, FilesThatCannotBeReadSaySo) {
  const auto missing = (std::filesystem::temp_directory_path() / "lbpkit-no-such-machine.toml").string();
  try {
    (void)config::loadMachine(missing);
    ADD_FAILURE() << "loaded a file that is not there";
  } catch (const config::FileError& e) {
    EXPECT_EQ(std::string(e.what()),
              missing + ": no such file (a machine file, or a built-in machine: mill, lathe or gantry)");
  }
  // A TOML syntax error: file, line and column from the parser.
  const auto message = error("[[axis]]\nname = \"x\n");
  EXPECT_EQ(message.rfind(path_ + ":2:", 0), 0U) << message;
  // A directory is not a machine file.
  const auto dir = std::filesystem::temp_directory_path() / ("lbpkit-machine-dir-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  try {
    (void)config::loadMachine(dir.string());
    ADD_FAILURE() << "loaded a directory";
  } catch (const config::FileError& e) {
    EXPECT_EQ(std::string(e.what()), dir.string() + ": is not a regular file (a TOML machine file is expected)");
  }
  std::filesystem::remove(dir);
  // FileError is what the app prints: a std::runtime_error.
  static_assert(std::is_base_of_v<std::runtime_error, config::FileError>);
}

// The card configuration reader moved with it: unchanged messages.
TEST_F(MachineFile, CardConfigurationStillNamesFileLineAndKey) {
  hm2::HostMot2Card::Options card;
  const auto& path = write("[[daughtercard]]\ntype = \"7I77D\"\nfield_voltage = 12\n", "card.toml");
  config::loadConfig(path, card);
  EXPECT_EQ(card.first.fieldIo.outputs, remote::OutputType::Sinking);
  EXPECT_EQ(card.first.fieldIo.fieldVoltage, 12.0);
  write("[[daughtercard]]\nfield_io_unit = 5\n", "card.toml");
  try {
    config::loadConfig(path_, card);
    ADD_FAILURE() << "took a bad unit number";
  } catch (const config::FileError& e) {
    EXPECT_EQ(std::string(e.what()),
              path_ + ":2:17: daughtercard[0].field_io_unit: 0x5 is out of range: 0x12000000 to 0x12FFFFFF");
  }
}

}  // namespace
