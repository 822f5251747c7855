// SPDX-License-Identifier: MIT
// A joint of a LinuxCNC configuration as a machine file's axis: what moves
// it (a PID whose output reaches a 7I77 analog output, a servo drive; or a
// hostmot2 StepGen, a stepper), what reads it back (an encoder: its lines
// and direction from hostmot2's encoder scale), and the travel, homing and
// switches its [JOINT_n] section gives (MIN_LIMIT, MAX_LIMIT,
// HOME_SEARCH_VEL, HOME_LATCH_VEL, HOME_USE_INDEX, HOME_OFFSET).
#pragma once

#include <optional>
#include <string>

#include "linuxcnc/derive_common.hpp"
#include "linuxcnc/derive_context.hpp"

namespace lbpkit::linuxcnc::detail {

// A joint as the steps of its derivation find it.
struct Joint {
  unsigned n = 0;
  std::string name;           // the axis's ("x")
  std::string jp;             // its pins: "joint.0."
  std::string section;        // its INI section: "JOINT_0"
  Where iniAt;                // where that section is
  std::string fbSig, cmdSig;  // the signals on motor-pos-fb and motor-pos-cmd
  std::string pid;            // the PID on its command, or ""
  // What moves it and reads it back, on the card `board` ("hm2_7i92.0").
  std::optional<unsigned> encoder, analog, stepgen;
  std::string board, analogPin, encoderPin;
  bool velocityStepgen = false;  // a StepGen in velocity mode, through the PID
  // Its [JOINT_n] values, as given (limits and HOME_OFFSET within bounds).
  bool angular = false;
  double mmPerUnit = 1.0;
  std::optional<Value> minLimit, maxLimit, homeOffset, maxVel, maxAcc, searchVel, latchVel;
  double vmax = 0.0, amax = 0.0;  // MAX_VELOCITY, MAX_ACCELERATION (or what is assumed)
  double sv = 0.0, lv = 0.0;      // HOME_SEARCH_VEL, HOME_LATCH_VEL
  Value offset;                   // HOME_OFFSET
  bool useIndex = false;          // HOME_USE_INDEX
  std::string unitName;           // "mm", "inch", "degrees"
  // The assumed screw, and the gearing its encoder's lines make exact.
  double pitch = 5.0, gear = 1.0;
};

// Joint n ([KINS]JOINTS) as the axis `name`, into c.out, claiming what
// drives it; a warning or an error, and no axis, when it cannot be.
void deriveAxis(DeriveContext& c, unsigned n, char letter, const std::string& name);

}  // namespace lbpkit::linuxcnc::detail
