// SPDX-License-Identifier: MIT
// lbpkit machine --from-config: the machine a LinuxCNC configuration for a
// 7I77 expects, worked out backwards from its INI and HAL files, as a
// machine file (examples/machines/mill.toml is the schema). Each joint
// whose PID drives a 7I77 analog output and reads an encoder becomes a
// servo axis (encoder lines and direction from the encoder's scale, the
// drive's gain and direction from the analog output's scalemax and the
// PID's FF1), each joint on a StepGen a stepper axis; switches go where the
// joint's homing (HOME_SEARCH_VEL, HOME_LATCH_VEL, HOME_USE_INDEX,
// HOME_OFFSET) and limits find them, on the inputs the HAL files net them
// to (normally closed where the net takes input-NN-not); the E-stop chain,
// the probe, the spindle, the field outputs and the brakes likewise. Signals
// are followed through the HAL components a configuration puts between a
// switch and what it stops (not, and2, or2, xor2, logic, debounce,
// timedelay, estop_latch, oneshot, edge, toggle; setp and sets constants),
// and every interlock that must read one way for the machine to run
// (motion.feed-inhibit, motion.enable, a message's trigger, ...) is held
// that way by the resting state of the inputs that decide it. Every value
// carries a comment naming the INI key or HAL line it came from; what a
// configuration cannot say (the screw's pitch, masses) is a stated
// assumption. A value no machine has (JOINTS past LinuxCNC's 16, a scale,
// velocity or position past the bounds in derive_common.hpp, or one
// that gives a machine file value past its own) is an error at the INI's or
// HAL's file and line, so a machine derived always loads. Needs no LinuxCNC.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "linuxcnc/hal_config.hpp"

namespace lbpkit::linuxcnc {

struct DerivedMachine {
  std::string toml;  // the machine file; empty when an error leaves no machine
  // Errors: what it could not understand (file, line, what is missing);
  // warnings: what it left out, and why.
  std::vector<Finding> findings;
  [[nodiscard]] bool ok() const;
};

DerivedMachine machineFromConfig(const std::filesystem::path& ini);

// A number a configuration gives: a setp of a HAL name (after [SECTION]KEY
// substitution), an INI key, or a default.
struct ConfigValue {
  double v = 0.0;
  std::string from;  // for a comment: "mill.hal:83: setp NAME [JOINT_0]OUTPUT_SCALE = 250"
  std::string said;  // for a finding: "[JOINT_0]OUTPUT_SCALE = 250"
  Where at;          // where the value is written: the INI's line for a setp of [SECTION]KEY
  Where setp;        // the setp's own line (line 0: no setp gives it)
};

// A joint whose PID's output reaches a 7I77's analogoutN, followed as
// machineFromConfig() follows it: the PID on the joint's motor-pos-cmd, the
// analog output on the PID's output (any 7I77's), its INI section and values.
struct AnalogDrive {
  unsigned joint = 0;
  std::string section;  // JOINT_N; AXIS_N or AXIS_L in a LinuxCNC 2.7 INI
  std::string pid;      // "pid.x"
  std::string output;   // "hm2_7i92.0.7i77.0.1.analogout0"
  Where outputAt;       // the first line that names it
  // hostmot2's parameters of the output (LinuxCNC:
  // src/hal/drivers/mesa-hostmot2/sserial.c): the PID's output is held to
  // [minlim, maxlim], then scaled so that scalemax gives 10 V. Each from its
  // setp (scalemax else [section]OUTPUT_SCALE), else hostmot2's default, the
  // range the 7I77 gives its analog outputs: scalemax 10, maxlim 10, minlim
  // -10.
  ConfigValue scalemax, maxlim, minlim;
  std::optional<ConfigValue> ff1;          // setp of the PID's FF1, else [section]FF1
  std::optional<ConfigValue> maxVelocity;  // [section]MAX_VELOCITY
  // The velocity (units/s) a PID output of `pidOutput` commands: with FF1
  // (velocity feed-forward) the PID's output is FF1 x the commanded velocity,
  // and the drive is set up to match. None without an FF1 above 0.
  [[nodiscard]] std::optional<double> velocityAt(double pidOutput) const;
};

// Every joint of the configuration `hal` (read from the INI `ini`) whose PID
// drives an analogoutN of a 7I77, in joint order.
std::vector<AnalogDrive> analogDrives(const HalConfig& hal, const std::filesystem::path& ini);

}  // namespace lbpkit::linuxcnc
