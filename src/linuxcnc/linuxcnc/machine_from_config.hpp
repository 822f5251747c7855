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
// velocity or position past the bounds in machine_from_config.cpp, or one
// that gives a machine file value past its own) is an error at the INI's or
// HAL's file and line, so a machine derived always loads. Needs no LinuxCNC.
#pragma once

#include <filesystem>
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

}  // namespace lbpkit::linuxcnc
