// SPDX-License-Identifier: MIT
// lbpkit machine --from-config: the machine a configuration expects. The
// example mill's configuration gives back the machine it was written for;
// negative scales give a reversed drive and encoder; switches land where
// homing and the nets put them; each public configuration under
// tests/public_configs/ either gives a machine that loads or an error
// naming the file, line and what is missing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "config/machine_toml.hpp"
#include "linuxcnc/machine_from_config.hpp"
#include "support/process.hpp"
#include "support/sim_child.hpp"
#include "support/temp_dir.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace machine = lbpkit::model::machine;
namespace config = lbpkit::config;

namespace {

namespace fs = std::filesystem;
using lbpkit::linuxcnc::machineFromConfig;

const fs::path kSource = LBPKIT_SOURCE_DIR;

// The derived machine loaded as lbpkit sim loads it.
machine::MachineDescription load(const lbpkit::linuxcnc::DerivedMachine& m) {
  test_support::TempDir dir;
  const auto file = dir.path() / "derived.toml";
  std::ofstream(file) << m.toml;
  return config::loadMachineFile(file.string());
}

const machine::SwitchParameters& switchNamed(const machine::MachineDescription& d, const std::string& name) {
  for (const auto& s : d.switches)
    if (s.name == name) return s;
  throw std::runtime_error("no switch " + name);
}

std::string errors(const lbpkit::linuxcnc::DerivedMachine& m) {
  std::string out;
  for (const auto& f : m.findings) out += f.file + ":" + std::to_string(f.line) + ": " + f.severity + ": " + f.reason + "\n";
  return out;
}

TEST(MachineFromConfig, TheExampleMillGivesTheMillItIsWiredFor) {
  const auto m = machineFromConfig(kSource / "examples/linuxcnc/mill/mill.ini");
  ASSERT_TRUE(m.ok()) << errors(m);
  const auto d = load(m);
  const auto mill = machine::mill();
  ASSERT_EQ(d.axes.size(), 3U);
  for (std::size_t i = 0; i < 3; ++i) {
    SCOPED_TRACE(mill.axes[i].name);
    const auto& a = d.axes[i];
    EXPECT_EQ(a.name, mill.axes[i].name);
    EXPECT_EQ(a.travelMin, mill.axes[i].travelMin);
    EXPECT_EQ(a.travelMax, mill.axes[i].travelMax);
    ASSERT_EQ(a.drives.size(), 1U);
    EXPECT_EQ(a.drives[0].analogOutput, i);
    EXPECT_EQ(a.drives[0].encoderInput, i);
    // 1600 counts/mm on a 5 mm screw: the mill's 2000 lines; 250 mm/s at
    // 10 V with FF1 = 1: 5 rev/s per volt.
    EXPECT_EQ(a.drives[0].encoder.linesPerRev, mill.axes[i].drives[0].encoder.linesPerRev);
    EXPECT_DOUBLE_EQ(a.drives[0].amplifier.gain, mill.axes[i].drives[0].amplifier.gain);
    EXPECT_FALSE(a.drives[0].amplifier.reversed);
    EXPECT_FALSE(a.drives[0].encoder.reversed);
  }
  // Home switches on inputs 0, 3, 6, their edges half a motor turn (2.5 mm)
  // before the index LinuxCNC calls HOME_OFFSET (390, 290, -10), searched
  // upwards; NC limits on 1, 2, 4, 5, 7, 8 past the travel; the E-stop
  // chain on 9 (NC: the net takes input-09 as it is), the probe on 10.
  const auto& xHome = switchNamed(d, "x-home");
  EXPECT_EQ(xHome.input, 0U);
  EXPECT_EQ(xHome.position, 392.5);
  EXPECT_TRUE(xHome.tripAbove);
  EXPECT_EQ(switchNamed(d, "y-home").input, 3U);
  EXPECT_EQ(switchNamed(d, "z-home").position, -7.5);
  for (const auto& [name, input] : std::map<std::string, unsigned>{
           {"x-min", 1}, {"x-max", 2}, {"y-min", 4}, {"y-max", 5}, {"z-min", 7}, {"z-max", 8}}) {
    SCOPED_TRACE(name);
    const auto& s = switchNamed(d, name);
    EXPECT_EQ(s.input, input);
    EXPECT_TRUE(s.contact == machine::Contact::NormallyClosed);
  }
  EXPECT_LT(switchNamed(d, "x-min").position, 0.0);
  EXPECT_GT(switchNamed(d, "x-max").position, 400.0);
  EXPECT_EQ(switchNamed(d, "estop").input, 9U);
  EXPECT_TRUE(switchNamed(d, "estop").contact == machine::Contact::NormallyClosed);
  EXPECT_EQ(switchNamed(d, "probe").input, 10U);
  EXPECT_FALSE(switchNamed(d, "probe").contact == machine::Contact::NormallyClosed);
  ASSERT_TRUE(d.spindle.has_value());
  EXPECT_EQ(d.spindle->analogOutput, 5U);
  EXPECT_EQ(d.spindle->vfd.rpmPerVolt, 2400.0);
  EXPECT_EQ(d.spindle->encoderInput, 5U);
  EXPECT_EQ(d.spindle->encoder.linesPerRev, 256U);
  ASSERT_EQ(d.outputs.size(), 3U);
  EXPECT_EQ(d.outputs[0].name, "coolant-flood");
  // Every value says where it came from.
  EXPECT_NE(m.toml.find("[JOINT_0]ENCODER_SCALE = 1600"), std::string::npos);
  EXPECT_NE(m.toml.find("mill.hal:"), std::string::npos);
  EXPECT_NE(m.toml.find("assumed"), std::string::npos);
}

TEST(MachineFromConfig, NegativeScalesHomingAndPermissives) {
  const auto m = machineFromConfig(kSource / "tests/machine_from_config/reversed/reversed.ini");
  ASSERT_TRUE(m.ok()) << errors(m);
  const auto d = load(m);
  ASSERT_EQ(d.axes.size(), 2U);
  const auto& x = d.axes[0];
  // OUTPUT_SCALE -10 and ENCODER_SCALE -1000: the motor and the encoder
  // both turn the other way; 1000 counts/mm on the assumed 5 mm screw: 1250
  // lines; 1 mm/s per volt over FF1 1 is 0.2 rev/s per volt.
  EXPECT_TRUE(x.drives[0].amplifier.reversed);
  EXPECT_TRUE(x.drives[0].encoder.reversed);
  EXPECT_EQ(x.drives[0].encoder.linesPerRev, 1250U);
  EXPECT_DOUBLE_EQ(x.drives[0].amplifier.gain, 0.2);
  // Homing down (HOME_SEARCH_VEL -10) onto input 0 read as input-00-not
  // (NC), latching up (HOME_LATCH_VEL 1) onto the index at HOME_OFFSET -200:
  // the edge half a motor turn below it.
  const auto& home = switchNamed(d, "x-home");
  EXPECT_EQ(home.input, 0U);
  EXPECT_TRUE(home.contact == machine::Contact::NormallyClosed);
  EXPECT_FALSE(home.tripAbove);
  EXPECT_EQ(home.position, -202.5);
  EXPECT_LE(x.travelMin, -202.5);
  // The index comes at whole motor turns from where the machine powers up:
  // it starts a whole number of turns (5 mm) from HOME_OFFSET, so the index
  // the latch finds is the one at -200.
  EXPECT_NEAR(std::remainder(x.initialPosition + 200.0, 5.0), 0.0, 1e-9) << x.initialPosition;
  // Y: FF1 0.5 doubles the drive's gain (2 mm/s per volt / 0.5 on 5 mm:
  // 0.8 rev/s per volt); it homes in place, so it starts at HOME_OFFSET.
  EXPECT_DOUBLE_EQ(d.axes[1].drives[0].amplifier.gain, 0.8);
  EXPECT_EQ(d.axes[1].initialPosition, 25.0);
  // The E-stop button through `not`: a NO contact; the lube sensor through
  // `not` into motion.feed-inhibit is held closed so that feed is allowed.
  EXPECT_EQ(switchNamed(d, "estop").input, 5U);
  EXPECT_FALSE(switchNamed(d, "estop").contact == machine::Contact::NormallyClosed);
  const auto& held = switchNamed(d, "held-12");
  EXPECT_EQ(held.input, 12U);
  EXPECT_TRUE(held.contact == machine::Contact::NormallyClosed);
  EXPECT_NE(m.toml.find("motion.feed-inhibit"), std::string::npos);
  // A signal named for a brake, written by the joint's amp-enable: X's brake.
  EXPECT_EQ(x.brakeOutput, 3);
}

// The public configurations (tests/public_configs/*/SOURCE.md): what each
// gives, or what each lacks, said where.
TEST(MachineFromConfig, PublicConfigurationsGiveAMachineOrSayWhatIsMissing) {
  const auto dir = kSource / "tests/public_configs";
  {
    // A 5I25 + 7I77 mill by PNCconf for LinuxCNC 2.7, in inches; each axis'
    // home switch is also both its limits (in series): one switch an input.
    const auto m = machineFromConfig(dir / "5i25-7i77-mill-floppydisk525/7i77v7.ini");
    ASSERT_TRUE(m.ok()) << errors(m);
    const auto d = load(m);
    EXPECT_EQ(d.axes.size(), 3U);
    EXPECT_NE(m.toml.find("25.4 to the inch"), std::string::npos);
    EXPECT_NE(errors(m).find("a machine file has one switch per input"), std::string::npos);
  }
  {
    // A 7I96S + 7I77 router, three servo axes and a spindle VFD.
    const auto m = machineFromConfig(dir / "7i96s-7i77-router-wrhammer/Rover13s.ini");
    ASSERT_TRUE(m.ok()) << errors(m);
    const auto d = load(m);
    EXPECT_EQ(d.axes.size(), 3U);
    EXPECT_TRUE(d.spindle.has_value());
  }
  {
    // Home switches on an Arduino (a Python component): no 7I77 input.
    const auto m = machineFromConfig(dir / "5i25-7i77-vmc-bendemott/tree_4024.ini");
    EXPECT_FALSE(m.ok());
    EXPECT_NE(errors(m).find("tree_4024.ini:128: error: joint 0: HOME_SEARCH_VEL is -5.0 but axis.0.home-sw-in "
                             "reaches no 7I77, 7I76 or card input (signal input-x-axis-limit (tree_4024.hal:68), with "
                             "mega2560.input-18"),
              std::string::npos)
        << errors(m);
  }
  {
    // A 7I92 + 7I77 lathe split into files joined by halcmd's `source`: the
    // card and its encoders in load.hal, the E-stop chain in inout.hal.
    const auto m = machineFromConfig(dir / "7i92-7i77-lathe-dowerna/padovani.ini");
    ASSERT_TRUE(m.ok()) << errors(m);
    const auto d = load(m);
    EXPECT_EQ(d.axes.size(), 2U);
    EXPECT_NE(m.toml.find("encoder_input = 1           # hm2_7i92.0.encoder.01 (padovani.hal:98)"), std::string::npos)
        << m.toml;
    EXPECT_NE(m.toml.find("hm2_7i92.0.7i77.0.0.input-10 (inout.hal:20) reaches iocontrol.0.emc-enable-in"),
              std::string::npos)
        << m.toml;
  }
  {
    // Y on an STMBL drive through a custom component: not a 7I77 axis.
    const auto m = machineFromConfig(dir / "7i80-7i77-router-shulter/justinbieber.ini");
    EXPECT_FALSE(m.ok());
    EXPECT_NE(errors(m).find("justinbieber.hal:89: error: joint 1: neither a PID whose output reaches a 7I77 "
                             "analogoutN nor a StepGen takes its command (signal yposcmd)"),
              std::string::npos)
        << errors(m);
  }
}

TEST(MachineFromConfig, WhatIsNotAConfigurationSaysSo) {
  test_support::TempDir dir;
  EXPECT_NE(errors(machineFromConfig(dir.path() / "absent.ini")).find("absent.ini:0: error: no such file"),
            std::string::npos);
  EXPECT_NE(errors(machineFromConfig(kSource / "examples/linuxcnc/mill/mill.hal")).find("from a configuration's INI"),
            std::string::npos);
  std::ofstream(dir.path() / "empty.ini") << "[EMC]\nVERSION = 1.1\n";
  const auto m = machineFromConfig(dir.path() / "empty.ini");
  EXPECT_FALSE(m.ok());
  EXPECT_TRUE(m.toml.empty());
  EXPECT_NE(errors(m).find("no joint drives a 7I77 analog output or a StepGen"), std::string::npos) << errors(m);
}

// The example mill's configuration copied into `dir` with its INI named
// `name`, and `key` in [JOINT_0] (or the first `key` anywhere, for a
// section-less key like JOINTS) set to `value` when given.
fs::path millCopy(const test_support::TempDir& dir, const std::string& name, const std::string& key = {},
                  const std::string& value = {}) {
  for (const auto& e : fs::directory_iterator(kSource / "examples/linuxcnc/mill"))
    fs::copy_file(e.path(), dir.path() / e.path().filename(), fs::copy_options::overwrite_existing);
  std::ifstream in(dir.path() / "mill.ini");
  std::string text, line;
  bool inJoint0 = false, done = key.empty();
  while (std::getline(in, line)) {
    if (line.starts_with("[")) inJoint0 = line == "[JOINT_0]";
    if (!done && (inJoint0 || key == "JOINTS") && line.starts_with(key + " =")) {
      line = key + " = " + value;
      done = true;
    }
    text += line + "\n";
  }
  if (!done) throw std::runtime_error("mill.ini has no " + key);
  const auto ini = dir.path() / name;
  std::ofstream(ini) << text;
  return ini;
}

// The line of `key` in [JOINT_0] of the mill's INI (JOINTS: in [KINS]).
unsigned lineOf(const std::string& key) {
  std::ifstream in(kSource / "examples/linuxcnc/mill/mill.ini");
  std::string line;
  bool inJoint0 = false;
  for (unsigned n = 1; std::getline(in, line); ++n) {
    if (line.starts_with("[")) inJoint0 = line == "[JOINT_0]";
    if ((inJoint0 || key == "JOINTS") && line.starts_with(key + " =")) return n;
  }
  return 0;
}

// A file name is no machine name: a machine file's name allows letters,
// digits, '_' and '-', so the INI's name is made one; nothing in it is run.
TEST(MachineFromConfig, AnyIniFileNameGivesAMachine) {
  test_support::TempDir dir;
  const std::string name = "a'$(touch PWNED2)'.ini";
  const auto m = machineFromConfig(millCopy(dir, name));
  ASSERT_TRUE(m.ok()) << errors(m);
  EXPECT_EQ(load(m).name, "a---touch-PWNED2--");
  // 41 characters and a newline: cut to 40, and the comment naming the
  // file stays one line.
  const auto m2 = machineFromConfig(millCopy(dir, std::string(41, 'n') + "\n\xff.ini"));
  ASSERT_TRUE(m2.ok()) << errors(m2);
  EXPECT_EQ(load(m2).name, std::string(40, 'n'));
  EXPECT_FALSE(fs::exists(dir.path() / "PWNED2"));
  EXPECT_FALSE(fs::exists("PWNED2"));
}

// LinuxCNC has 1 to EMCMOT_MAX_JOINTS (16) joints: anything else is refused
// at its line, at once (4000000000 made lbpkit build that many).
TEST(MachineFromConfig, JointsPastLinuxCncsAreRefusedAtTheirLine) {
  for (const std::string joints : {"4000000000", "-5", "0", "1e300", "17", "2.5", "nan"}) {
    SCOPED_TRACE(joints);
    test_support::TempDir dir;
    const auto m = machineFromConfig(millCopy(dir, "mill.ini", "JOINTS", joints));
    EXPECT_FALSE(m.ok());
    EXPECT_NE(errors(m).find(fmt::format("mill.ini:{}: error: [KINS]JOINTS = {} is not a number of joints LinuxCNC "
                                         "has: 1 to 16",
                                         lineOf("JOINTS"), joints)),
              std::string::npos)
        << errors(m);
  }
}

// A scale, a velocity or a position no machine has is refused at the INI's
// line with its key; values at the edge of the bounds give a machine that
// loads; no machine file holds nan or inf.
TEST(MachineFromConfig, ValuesNoMachineHasAreRefusedAtTheirLine) {
  struct Case {
    std::string key, value, what;
  };
  for (const Case& c : {Case{"ENCODER_SCALE", "1e308", "is not a scale a machine can have"},
                        Case{"ENCODER_SCALE", "1e-320", "is not a scale a machine can have"},
                        Case{"ENCODER_SCALE", "inf", "is not a scale a machine can have"},
                        Case{"ENCODER_SCALE", "1e7", "encoder lines a motor turn of 1.25e+07"},
                        Case{"OUTPUT_SCALE", "1e308", "is not an output scale a machine can have"},
                        Case{"OUTPUT_SCALE", "-0", "is not an output scale a machine can have"},
                        Case{"HOME_SEARCH_VEL", "1e308", "is not a velocity a machine can have"},
                        Case{"HOME_LATCH_VEL", "nan", "is not a velocity a machine can have"},
                        Case{"MAX_VELOCITY", "-1e300", "is not a velocity a machine can have"},
                        Case{"MAX_ACCELERATION", "1e-300", "hard stops (mm) past the travel"},
                        Case{"MIN_LIMIT", "-1e300", "is not a position a machine can have"},
                        Case{"HOME_OFFSET", "1e99", "is not a position a machine can have"}}) {
    SCOPED_TRACE(c.key + " = " + c.value);
    test_support::TempDir dir;
    const auto m = machineFromConfig(millCopy(dir, "mill.ini", c.key, c.value));
    EXPECT_FALSE(m.ok());
    EXPECT_TRUE(m.toml.empty());
    const auto said = fmt::format("mill.ini:{}: error: [JOINT_0]{} = {}", lineOf(c.key), c.key, c.value);
    EXPECT_NE(errors(m).find(said), std::string::npos) << errors(m);
    EXPECT_NE(errors(m).find(c.what), std::string::npos) << errors(m);
  }
  {
    // FF1 divides the output scale: the gain is said at OUTPUT_SCALE.
    test_support::TempDir dir;
    const auto m = machineFromConfig(millCopy(dir, "mill.ini", "FF1", "1e-12"));
    EXPECT_NE(errors(m).find(fmt::format("mill.ini:{}: error: [JOINT_0]OUTPUT_SCALE = 250: over FF1 1e-12 (mill.ini:{}), "
                                         "a drive gain (motor rev/s per V) of 5e+12",
                                         lineOf("OUTPUT_SCALE"), lineOf("FF1"))),
              std::string::npos)
        << errors(m);
  }
  for (const Case& c : {Case{"ENCODER_SCALE", "8e5", ""}, Case{"ENCODER_SCALE", "-1e-3", ""},
                        Case{"OUTPUT_SCALE", "-4000", ""}, Case{"HOME_SEARCH_VEL", "-1e3", ""},
                        Case{"MAX_VELOCITY", "1e3", ""}, Case{"MIN_LIMIT", "-99999", ""},
                        Case{"HOME_OFFSET", "99999", ""}, Case{"FF1", "0.05", ""}}) {
    SCOPED_TRACE(c.key + " = " + c.value);
    test_support::TempDir dir;
    const auto m = machineFromConfig(millCopy(dir, "mill.ini", c.key, c.value));
    ASSERT_TRUE(m.ok()) << errors(m);
    EXPECT_NO_THROW((void)load(m));
    EXPECT_EQ(m.toml.find("nan"), std::string::npos);
    EXPECT_EQ(m.toml.find("inf"), std::string::npos);
  }
}

// Two inputs reaching one joint's home-sw-in (through or2): two home
// switches, each with a name of its own.
TEST(MachineFromConfig, TwoInputsOnOneHomeGiveTwoNamedSwitches) {
  test_support::TempDir dir;
  const auto ini = millCopy(dir, "mill.ini");
  std::ifstream in(dir.path() / "mill.hal");
  std::string hal, line;
  while (std::getline(in, line)) {
    if (line == "net home-x         <=  hm2_7i92.0.7i77.0.0.input-00")
      line = "loadrt or2 count=1\naddf or2.0 servo-thread\nnet home-x-a <= hm2_7i92.0.7i77.0.0.input-00 => or2.0.in0\n"
             "net home-x-b <= hm2_7i92.0.7i77.0.0.input-20 => or2.0.in1\nnet home-x <= or2.0.out";
    hal += line + "\n";
  }
  ASSERT_NE(hal.find("or2.0.out"), std::string::npos);
  std::ofstream(dir.path() / "mill.hal") << hal;
  const auto m = machineFromConfig(ini);
  ASSERT_TRUE(m.ok()) << errors(m);
  const auto d = load(m);
  EXPECT_EQ(switchNamed(d, "x-home").input, 0U);
  EXPECT_EQ(switchNamed(d, "x-home-2").input, 20U);
}

// The interlocks fixture (tests/machine_from_config/interlocks/: one servo
// axis homing in place) copied into `dir`, with `hal` added to its HAL
// file.
fs::path interlocks(const test_support::TempDir& dir, const std::string& hal) {
  const auto from = kSource / "tests/machine_from_config/interlocks";
  fs::copy_file(from / "interlocks.ini", dir.path() / "interlocks.ini", fs::copy_options::overwrite_existing);
  std::ifstream in(from / "interlocks.hal");
  std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  std::ofstream(dir.path() / "interlocks.hal") << text << hal;
  return dir.path() / "interlocks.ini";
}

// Whether `text` holds `part`; when not, the text to read.
::testing::AssertionResult holds(const std::string& text, const std::string& part) {
  if (text.find(part) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "no \"" << part << "\" in:\n" << text;
}

// The line of `file` that holds `text` (0: none).
unsigned lineWith(const fs::path& file, const std::string& text) {
  std::ifstream in(file);
  std::string line;
  for (unsigned n = 1; std::getline(in, line); ++n)
    if (line.find(text) != std::string::npos) return n;
  return 0;
}

// The two-7I77 fixture (tests/machine_from_config/two-7i77s/) copied into
// `dir`, `from` replaced by `to` in its HAL file when given.
fs::path twoSevenI77s(const test_support::TempDir& dir, const std::string& from = {}, const std::string& to = {}) {
  const auto src = kSource / "tests/machine_from_config/two-7i77s";
  fs::copy_file(src / "two_7i77s.ini", dir.path() / "two_7i77s.ini", fs::copy_options::overwrite_existing);
  std::ifstream in(src / "two_7i77s.hal");
  std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  if (!from.empty()) {
    const auto at = text.find(from);
    if (at == std::string::npos) throw std::runtime_error("two_7i77s.hal has no " + from);
    text.replace(at, from.size(), to);
  }
  std::ofstream(dir.path() / "two_7i77s.hal") << text;
  return dir.path() / "two_7i77s.ini";
}

// A card with two 7I77s (the 7I77x2 firmware: the second on smart-serial
// channels 3 and 4, counters 6 to 11): the machine is the first 7I77's, and
// each pin of the second is left out at its line, never taken as the first
// 7I77's terminal of that number.
TEST(MachineFromConfig, TheSecondSevenI77sPinsAreLeftOutAtTheirLine) {
  const auto m = machineFromConfig(kSource / "tests/machine_from_config/two-7i77s/two_7i77s.ini");
  ASSERT_TRUE(m.ok()) << errors(m);
  const auto all = errors(m);
  const std::string behind = ", and lbpkit's derived machine sits behind the first 7I77 only, so this pin is left out";
  EXPECT_TRUE(holds(all, "two_7i77s.hal:22: warning: hm2_7i92.0.7i77.0.3.input-05 is on the second 7I77 "
                         "(smart-serial channel 3)" + behind));
  EXPECT_TRUE(holds(all, "two_7i77s.hal:28: warning: hm2_7i92.0.7i77.0.3.output-02 is on the second 7I77 "
                         "(smart-serial channel 3)" + behind));
  EXPECT_TRUE(holds(all, "two_7i77s.hal:30: warning: hm2_7i92.0.7i77.0.4.analogout1 is on the second 7I77 "
                         "(smart-serial channel 4)" + behind));
  EXPECT_EQ(std::count(all.begin(), all.end(), '\n'), 3) << all;
  // The first 7I77's pins derive as on a card with one 7I77.
  const auto d = load(m);
  ASSERT_EQ(d.axes.size(), 2U);
  EXPECT_EQ(d.axes[0].drives[0].analogOutput, 0U);
  EXPECT_EQ(d.axes[0].drives[0].encoderInput, 0U);
  EXPECT_EQ(d.axes[1].drives[0].analogOutput, 1U);
  EXPECT_EQ(d.axes[1].drives[0].encoderInput, 1U);
  EXPECT_EQ(switchNamed(d, "x-home").input, 0U);
  EXPECT_EQ(switchNamed(d, "estop").input, 5U);
  EXPECT_EQ(d.axes[0].brakeOutput, 3);
  // Y's limit (the second's input 5) is no switch on the first's input 5,
  // the coolant (its output 2) no output 2, its analogout1 no spindle.
  ASSERT_EQ(d.switches.size(), 2U);
  ASSERT_EQ(d.outputs.size(), 1U);
  EXPECT_EQ(d.outputs[0].output, 3U);
  EXPECT_FALSE(d.spindle.has_value());
}

// A joint whose drive or feedback is on the second 7I77 cannot be derived:
// an error at the joint's line naming the pin.
TEST(MachineFromConfig, AJointOnTheSecondSevenI77IsAnErrorAtItsLine) {
  {
    test_support::TempDir dir;
    const auto ini = twoSevenI77s(dir, "pid.y.output => hm2_7i92.0.7i77.0.1.analogout1",
                                  "pid.y.output => hm2_7i92.0.7i77.0.4.analogout0");
    const auto m = machineFromConfig(ini);
    EXPECT_FALSE(m.ok());
    const auto hal = dir.path() / "two_7i77s.hal";
    EXPECT_TRUE(holds(errors(m),
                      fmt::format("two_7i77s.hal:{}: error: joint 1: its PID drives hm2_7i92.0.7i77.0.4.analogout0 "
                                  "(two_7i77s.hal:{}), on the second 7I77 (smart-serial channel 4), and lbpkit's "
                                  "derived machine sits behind the first 7I77 only, so this joint cannot be derived",
                                  lineWith(hal, "joint.1.motor-pos-cmd"), lineWith(hal, "0.4.analogout0"))));
  }
  {
    test_support::TempDir dir;
    const auto ini = twoSevenI77s(dir, "hm2_7i92.0.encoder.01.position", "hm2_7i92.0.encoder.07.position");
    const auto m = machineFromConfig(ini);
    EXPECT_FALSE(m.ok());
    const auto hal = dir.path() / "two_7i77s.hal";
    const auto line = lineWith(hal, "encoder.07.position");
    EXPECT_TRUE(holds(errors(m), fmt::format("two_7i77s.hal:{}: error: joint 1: its feedback "
                                             "hm2_7i92.0.encoder.07.position (two_7i77s.hal:{}) is a counter of the "
                                             "second 7I77 (6 to 11): lbpkit's derived machine sits behind the first "
                                             "7I77 only, so this joint cannot be derived",
                                             line, line)));
  }
}

// Whether 7I77 input `input` reads on while the machine rests: a NC switch
// on it (closed until it trips) reads on; a NO switch, or none, off.
bool restsOn(const machine::MachineDescription& d, unsigned input) {
  for (const auto& s : d.switches)
    if (s.input == input && s.daughtercard == machine::Daughtercard::SevenI77)
      return s.contact == machine::Contact::NormallyClosed;
  return false;
}
bool hasSwitchOn(const machine::MachineDescription& d, unsigned input) {
  return std::any_of(d.switches.begin(), d.switches.end(), [&](const auto& s) { return s.input == input; });
}

// One kind of component between a sensor and an interlock: the HAL lines
// added to the interlocks fixture, the 7I77 inputs that must rest on and
// off, and what the machine file says of one.
struct ComponentCase {
  std::string name;
  std::string hal;
  std::vector<unsigned> on, off;
  std::string said;
};
std::ostream& operator<<(std::ostream& o, const ComponentCase& c) { return o << c.name; }

class MachineFromConfigComponent : public ::testing::TestWithParam<ComponentCase> {};

TEST_P(MachineFromConfigComponent, HoldsItsInputsTheWayTheMachineRuns) {
  const auto& c = GetParam();
  test_support::TempDir dir;
  const auto m = machineFromConfig(interlocks(dir, c.hal));
  ASSERT_TRUE(m.ok()) << errors(m);
  EXPECT_TRUE(m.findings.empty()) << errors(m);
  const auto d = load(m);
  for (const auto i : c.on) EXPECT_TRUE(restsOn(d, i)) << "input " << i;
  for (const auto i : c.off) EXPECT_FALSE(restsOn(d, i)) << "input " << i;
  EXPECT_TRUE(holds(m.toml, c.said));
}

INSTANTIATE_TEST_SUITE_P(
    Interlocks, MachineFromConfigComponent,
    ::testing::Values(
        // A sensor through `not` into motion.feed-inhibit: on at rest, so
        // that feed is allowed; one straight into motion.feed-hold: off.
        ComponentCase{"Not",
                      "loadrt not count=1\n"
                      "net lube-level hm2_7i92.0.7i77.0.0.input-03 => not.0.in\n"
                      "net lube-low not.0.out => motion.feed-inhibit\n"
                      "net hold hm2_7i92.0.7i77.0.0.input-04 => motion.feed-hold\n",
                      {3},
                      {4},
                      "# hm2_7i92.0.7i77.0.0.input-03 (interlocks.hal:16) must read on for motion.feed-inhibit to be "
                      "FALSE (through not.0): held closed\n[[switch]]\nname = \"held-3\"\nkind = \"other\""},
        // debounce's groups (cfg=: debounce.G.C) pass the input on once it
        // has stayed; timedelay likewise.
        ComponentCase{"Debounce",
                      "loadrt debounce cfg=2,3\n"
                      "loadrt timedelay count=1\n"
                      "net door hm2_7i92.0.7i77.0.0.input-05 => debounce.1.2.in\n"
                      "net door-closed debounce.1.2.out => motion.enable\n"
                      "net guard hm2_7i92.0.7i77.0.0.input-06 => debounce.0.0.in\n"
                      "net guard-open debounce.0.0.out => timedelay.0.in\n"
                      "net guard-late timedelay.0.out => spindle.0.inhibit\n",
                      {5},
                      {6},
                      "must read off for spindle.0.inhibit to be FALSE (through debounce.0.0, timedelay.0)"},
        // and2 TRUE: both inputs on; or2 FALSE: both off (input-09-not
        // FALSE: the input on); xor2 with its other input set TRUE by setp:
        // on.
        ComponentCase{"And2Or2Xor2",
                      "loadrt and2 count=1\n"
                      "loadrt or2 count=1\n"
                      "loadrt xor2 count=1\n"
                      "net a hm2_7i92.0.7i77.0.0.input-06 => and2.0.in0\n"
                      "net b hm2_7i92.0.7i77.0.0.input-07 => and2.0.in1\n"
                      "net ab and2.0.out => motion.enable\n"
                      "net c hm2_7i92.0.7i77.0.0.input-08 => or2.0.in0\n"
                      "net e hm2_7i92.0.7i77.0.0.input-09-not => or2.0.in1\n"
                      "net ce or2.0.out => halui.program.pause\n"
                      "net f hm2_7i92.0.7i77.0.0.input-10 => xor2.0.in0\n"
                      "setp xor2.0.in1 TRUE\n"
                      "net fx xor2.0.out => spindle.0.inhibit\n",
                      {6, 7, 9, 10},
                      {8},
                      "must read on for motion.enable to be TRUE (through and2.0): held closed"},
        // logic: its personality says how many inputs (in-00 on) and which
        // outputs (and, or, xor, nand, nor), one an instance named by names=.
        ComponentCase{"Logic",
                      "loadrt logic names=guards,spare personality=0x1103,0x802\n"
                      "net g0 hm2_7i92.0.7i77.0.0.input-11 => guards.in-00\n"
                      "net g1 hm2_7i92.0.7i77.0.0.input-12 => guards.in-01\n"
                      "net g2 hm2_7i92.0.7i77.0.0.input-13 => guards.in-02\n"
                      "net all-closed guards.and => motion.enable\n"
                      "net s0 hm2_7i92.0.7i77.0.0.input-14 => spare.in-00\n"
                      "setp spare.in-01 1\n"
                      "net spare-nand spare.nand => motion.feed-inhibit\n",
                      {11, 12, 13, 14},
                      {},
                      "must read on for motion.enable to be TRUE (through guards): held closed"},
        // A message fires when its trigger goes to its edge (TRUE unless
        // `edge` is set FALSE): the trigger is held the other way.
        ComponentCase{"Message",
                      "loadrt message names=oil-low,door-open messages=\"Slideway oil low,Door open\"\n"
                      "setp oil-low.edge 0\n"
                      "net oil hm2_7i92.0.7i77.0.0.input-15 => oil-low.trigger\n"
                      "net door hm2_7i92.0.7i77.0.0.input-16-not => door-open.trigger\n",
                      {15, 16},
                      {},
                      "must read on for oil-low.trigger to be TRUE (message oil-low \"Slideway oil low\" fires when it "
                      "goes FALSE): held closed"},
        // estop_latch between the E-stop inputs and emc-enable-in: OK while
        // ok-in is TRUE and fault-in FALSE, so ok-in's input is a NC button
        // and fault-in's a NO one; fault-out into motion.feed-hold agrees.
        ComponentCase{"EstopLatch",
                      "loadrt estop_latch\n"
                      "net estop-ok hm2_7i92.0.7i77.0.0.input-17 => estop-latch.0.ok-in\n"
                      "net drive-fault hm2_7i92.0.7i77.0.0.input-18 => estop-latch.0.fault-in\n"
                      "net reset iocontrol.0.user-request-enable => estop-latch.0.reset\n"
                      "net enable estop-latch.0.ok-out => iocontrol.0.emc-enable-in\n"
                      "net faulted estop-latch.0.fault-out => motion.feed-hold\n",
                      {17},
                      {18},
                      "# hm2_7i92.0.7i77.0.0.input-18 (interlocks.hal:17) reaches iocontrol.0.emc-enable-in inverted "
                      "(through estop-latch.0): NO, the input on while pressed\n[[switch]]\nname = \"estop2\"\n"
                      "kind = \"estop\""},
        // A component loaded with names= is followed by its names.
        ComponentCase{"Names",
                      "loadrt not names=lube-not,air-not\n"
                      "net lube hm2_7i92.0.7i77.0.0.input-19 => lube-not.in\n"
                      "net lube-low lube-not.out => motion.feed-inhibit\n"
                      "net air hm2_7i92.0.7i77.0.0.input-20 => air-not.in\n"
                      "net air-low air-not.out => motion.spindle-inhibit\n",
                      {19, 20},
                      {},
                      "(through air-not): held closed"},
        // A signal set by `sets` is a constant: what it leaves to the
        // input is held.
        ComponentCase{"Sets",
                      "loadrt and2 count=1\n"
                      "net door hm2_7i92.0.7i77.0.0.input-21 => and2.0.in0\n"
                      "net always and2.0.in1\n"
                      "sets always 1\n"
                      "net door-ok and2.0.out => motion.enable\n",
                      {21},
                      {},
                      "must read on for motion.enable to be TRUE (through and2.0): held closed"}),
    [](const ::testing::TestParamInfo<ComponentCase>& i) { return i.param.name; });

// An interlock that cannot be held: the HAL lines added to the interlocks
// fixture, the inputs left off, and the warning, each {TEXT} in it the
// number of the line of the HAL file that holds TEXT. The machine still
// loads.
struct WarningCase {
  std::string name;
  std::string hal;
  std::vector<unsigned> off;
  std::string said;
};
std::ostream& operator<<(std::ostream& o, const WarningCase& c) { return o << c.name; }

class MachineFromConfigWarning : public ::testing::TestWithParam<WarningCase> {};

TEST_P(MachineFromConfigWarning, IsSaidAtTheInterlocksLine) {
  const auto& c = GetParam();
  test_support::TempDir dir;
  const auto m = machineFromConfig(interlocks(dir, c.hal));
  ASSERT_TRUE(m.ok()) << errors(m);
  const auto d = load(m);
  for (const auto i : c.off) EXPECT_FALSE(hasSwitchOn(d, i)) << "input " << i;
  std::string said = c.said;
  for (auto open = said.find('{'); open != std::string::npos; open = said.find('{', open)) {
    const auto close = said.find('}', open);
    const auto line = std::to_string(lineWith(dir.path() / "interlocks.hal", said.substr(open + 1, close - open - 1)));
    said.replace(open, close - open + 1, line);
  }
  EXPECT_TRUE(holds(errors(m), said));
}

INSTANTIATE_TEST_SUITE_P(
    Interlocks, MachineFromConfigWarning,
    ::testing::Values(
        // A `sets` of 0 into an and2 that must be TRUE: no input gives it.
        WarningCase{"NoInputGivesIt",
                    "loadrt and2 count=1\n"
                    "net door hm2_7i92.0.7i77.0.0.input-21 => and2.0.in0\n"
                    "net never and2.0.in1\n"
                    "sets never 0\n"
                    "net door-ok and2.0.out => motion.enable\n",
                    {},
                    "interlocks.hal:{door-ok}: warning: motion.enable to be TRUE cannot be: no state of the field "
                    "inputs gives it (sets never 0 (interlocks.hal:{sets never}))"},
        // Two interlocks wanting one input opposite ways: the first is
        // held, the second said with the input and the first.
        WarningCase{"TwoInterlocksWantOppositeWays",
                    "loadrt not count=1\n"
                    "net door hm2_7i92.0.7i77.0.0.input-22 => motion.feed-inhibit not.0.in\n"
                    "net door-not not.0.out => motion.feed-hold\n",
                    {22},
                    "interlocks.hal:{door-not}: warning: motion.feed-hold to be FALSE cannot be held: "
                    "hm2_7i92.0.7i77.0.0.input-22 must read on for it (through not.0) but reads off for "
                    "motion.feed-inhibit to be FALSE (interlocks.hal:{net door })"},
        // A pulse (oneshot, edge) is over at rest and a toggle where it
        // started: what they feed reads that whatever the input.
        WarningCase{"PulsesAndTogglesRestAsTheyStart",
                    "loadrt oneshot count=1\n"
                    "loadrt edge count=1\n"
                    "loadrt toggle count=1\n"
                    "net bump hm2_7i92.0.7i77.0.0.input-23 => oneshot.0.in\n"
                    "net bumped oneshot.0.out => motion.feed-hold\n"
                    "net tap hm2_7i92.0.7i77.0.0.input-24 => edge.0.in\n"
                    "net tapped edge.0.out-invert => motion.enable\n"
                    "net button hm2_7i92.0.7i77.0.0.input-25 => toggle.0.in\n"
                    "net toggled toggle.0.out => spindle.0.at-speed\n",
                    {23, 24, 25},
                    "interlocks.hal:{toggled}: warning: spindle.0.at-speed to be TRUE cannot be: no state of the "
                    "field inputs gives it (toggle.0.out flips on each press of its input: FALSE as it starts)"}),
    [](const ::testing::TestParamInfo<WarningCase>& i) { return i.param.name; });

// The lube-level chain PNCconf's custom.hal gives a 5I25 mill: input-29
// through debounce.0.0 and not.0 into motion.feed-inhibit, held on; the
// homes and the external E-stop as before.
TEST(MachineFromConfigInterlocks, PncconfLubeLevelThroughDebounceAndNot) {
  const auto m = machineFromConfig(kSource / "tests/machine_from_config/pncconf-lube/pncconf_lube.ini");
  ASSERT_TRUE(m.ok()) << errors(m);
  const auto d = load(m);
  EXPECT_TRUE(restsOn(d, 29));
  EXPECT_TRUE(holds(m.toml, "hm2_5i25.0.7i77.0.0.input-29 (custom.hal:12) must read on for motion.feed-inhibit to "
                            "be FALSE (through debounce.0.0, not.0): held closed"));
  EXPECT_EQ(switchNamed(d, "estop").input, 30U);
  EXPECT_TRUE(restsOn(d, 30));
  EXPECT_EQ(switchNamed(d, "x-home").input, 0U);
}

// The chuck's clamp sensor through not, and2 (with spindle.0.on) and logic
// into a message: held closed so the message never fires; the drive's fault
// relay on the logic's other input rests open.
TEST(MachineFromConfigInterlocks, LatheClampThroughAnd2AndLogicIntoAMessage) {
  const auto m = machineFromConfig(kSource / "tests/machine_from_config/lathe-clamp/lathe_clamp.ini");
  ASSERT_TRUE(m.ok()) << errors(m);
  const auto d = load(m);
  EXPECT_TRUE(restsOn(d, 14));
  EXPECT_FALSE(restsOn(d, 15));
  EXPECT_FALSE(hasSwitchOn(d, 15));
  EXPECT_TRUE(holds(m.toml, "hm2_7i92.0.7i77.0.0.input-14 (custom.hal:16) must read on for clamp-msg.trigger to "
                            "be FALSE (message clamp-msg \"Can not start spindle with no CLAMP!\" fires when it goes "
                            "TRUE) (through clamp-open, and2.0, spindle-fault): held closed"));
  EXPECT_TRUE(d.spindle.has_value());
}

// One output on two signals (a second net after unlinkp) is one output
// whose comment names both; two signals whose names give one machine name
// give two names.
TEST(MachineFromConfigInterlocks, OneOutputOnTwoSignalsIsOneOutput) {
  test_support::TempDir dir;
  const auto ini = interlocks(dir,
                              "unlinkp hm2_7i92.0.7i77.0.0.output-00\n"
                              "net machine-on motion.motion-enabled => hm2_7i92.0.7i77.0.0.output-00\n"
                              "net estop.out halui.machine.is-on => hm2_7i92.0.7i77.0.0.output-01\n");
  const auto m = machineFromConfig(ini);
  ASSERT_TRUE(m.ok()) << errors(m);
  const auto d = load(m);
  ASSERT_EQ(d.outputs.size(), 2U);
  EXPECT_EQ(d.outputs[0].name, "estop-out");
  EXPECT_EQ(d.outputs[0].output, 0U);
  EXPECT_EQ(d.outputs[1].name, "estop-out-2");
  EXPECT_EQ(d.outputs[1].output, 1U);
  EXPECT_TRUE(holds(m.toml, "# hm2_7i92.0.7i77.0.0.output-00 (interlocks.hal:14), signal estop-out; also "
                            "hm2_7i92.0.7i77.0.0.output-00 (interlocks.hal:16), signal machine-on: one output"));
}

std::string fileBytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// lbpkit machine --from-config as a user (or lbpkit linuxcnc, as root) runs
// it: -o writes nothing over a running sim's EEPROM whatever --force says,
// names a missing folder, and every error names the user's file and line,
// never the temporary file the machine is checked in.
TEST(MachineFromConfigCli, OutputIsNeverASimsStateFileAndErrorsNameTheUsersFiles) {
  test_support::TempDir dir;
  const auto ini = millCopy(dir, "a'$(touch PWNED2)'.ini").string();
  const auto state = dir / "sim.eeprom";
  {
    test_support::Daemon sim({"sim", "--bind", "127.0.0.1:0", "--api", "0", "--state", state, "--ready-fd", "3"}, true);
    ASSERT_FALSE(test_support::lbp16Address(sim).empty());
    const auto before = fileBytes(state);
    const auto r = test_support::run({"machine", "--from-config", ini, "-o", state, "--force"});
    EXPECT_EQ(r.exit, 1);
    EXPECT_NE(r.err.find("-o " + state + ": is held locked by process"), std::string::npos) << r.err;
    EXPECT_EQ(fileBytes(state), before);
    EXPECT_EQ(sim.stop(), 0);
  }
  // Not running, the EEPROM image is still no machine file.
  auto r = test_support::run({"machine", "--from-config", ini, "-o", state, "--force"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find("-o " + state + ": exists and is not what this option writes"), std::string::npos) << r.err;

  r = test_support::run({"machine", "--from-config", ini, "-o", dir / "nodir/x.toml"});
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find("the folder " + (dir / "nodir") + " does not exist"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find(".part"), std::string::npos) << r.err;

  // The quote in the file name: a machine, written and on standard output.
  const auto out = dir / "out.toml";
  r = test_support::run({"machine", "--from-config", ini, "-o", out});
  EXPECT_EQ(r.exit, 0) << r.err;
  EXPECT_NO_THROW((void)config::loadMachineFile(out));
  r = test_support::run({"machine", "--from-config", ini});
  EXPECT_EQ(r.exit, 0) << r.err;
  EXPECT_NE(r.out.find("name = \"a---touch-PWNED2--\""), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "PWNED2"));
  EXPECT_FALSE(fs::exists("PWNED2"));

  // A hostile scale: said at the INI's line, with -o and without; nothing
  // written, nothing on standard output.
  const auto hostile = millCopy(dir, "hostile.ini", "ENCODER_SCALE", "1e308").string();
  for (const bool toFile : {true, false}) {
    std::vector<std::string> args{"machine", "--from-config", hostile};
    if (toFile) args.insert(args.end(), {"-o", dir / "hostile.toml"});
    r = test_support::run(args);
    EXPECT_EQ(r.exit, 1);
    EXPECT_TRUE(r.out.empty()) << r.out;
    EXPECT_NE(r.err.find(fmt::format("hostile.ini:{}: error: [JOINT_0]ENCODER_SCALE = 1e308 is not a scale",
                                     lineOf("ENCODER_SCALE"))),
              std::string::npos)
        << r.err;
    EXPECT_EQ(r.err.find(".part"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("a fault in lbpkit"), std::string::npos) << r.err;
  }
  EXPECT_FALSE(fs::exists(dir / "hostile.toml"));
}

}  // namespace
