// SPDX-License-Identifier: MIT
// The switches a configuration's machine has beside its axes': the E-stop
// chain (every field input whose state reaches iocontrol.0.emc-enable-in,
// LinuxCNC's iocontrol(1)) and the probe (motion.probe-input, motion(9)),
// each on the 7I77 or 7I76 field input the HAL files net to it.
#pragma once

#include "linuxcnc/derive_context.hpp"

namespace lbpkit::linuxcnc::detail {

// Every input reaching iocontrol.0.emc-enable-in as an E-stop switch, its
// contact what keeps emc-enable-in TRUE until pressed.
void deriveEstop(DeriveContext& c);
// The first input reaching motion.probe-input as the probe.
void deriveProbe(DeriveContext& c);

}  // namespace lbpkit::linuxcnc::detail
