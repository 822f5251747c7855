// SPDX-License-Identifier: MIT
// A configuration's joints as LinuxCNC names them: how many ([KINS]JOINTS,
// [TRAJ]AXES in 2.7, else the joint.N pins netted), their coordinate
// letters ([KINS]KINEMATICS coordinates=, [TRAJ]COORDINATES), each joint's
// pins (joint.N. since 2.8, axis.N. in 2.7) and INI section ([JOINT_N],
// [AXIS_N], [AXIS_L]), the PID on its command (pid(9)), and a servo joint's
// drive on a 7I77 analog output (hostmot2(9): scalemax, maxlim, minlim).
#pragma once

#include <string>
#include <vector>

#include "linuxcnc/derive_context.hpp"
#include "linuxcnc/machine_from_config.hpp"

namespace lbpkit::linuxcnc::detail {

// The number of joints (0 and an error when it is none LinuxCNC has); sets
// c.jointPinsName.
unsigned jointCount(DeriveContext& c);
// The joints' coordinate letters, upper case, in joint order.
std::string coordinates(const HalConfig& hal);
// Joint n's pins: LinuxCNC 2.8 and later name them joint.N; 2.7 axis.N.
std::string jointPins(const DeriveContext& c, unsigned n);
// Joint n's INI section: [JOINT_N] (2.8 and later), [AXIS_N] (2.7),
// [AXIS_L].
std::string sectionOf(const DeriveContext& c, unsigned n, char letter);
// The PID between a joint's command (signal `cmdSig`) and what drives the
// motor: the pid instance whose command is on it ("" when none).
std::string pidOn(const DeriveContext& c, const std::string& cmdSig);
// Joint n's drive through `pid` on the 7I77 analog output `output`.
AnalogDrive analogDrive(const DeriveContext& c, unsigned n, const std::string& section, const std::string& pid,
                        const std::string& output);
// Every joint whose PID drives an analogoutN of a 7I77 (analogDrives()).
std::vector<AnalogDrive> jointAnalogDrives(DeriveContext& c);

}  // namespace lbpkit::linuxcnc::detail
