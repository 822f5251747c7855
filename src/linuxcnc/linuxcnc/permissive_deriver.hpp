// SPDX-License-Identifier: MIT
// The interlocks and permissives that must read one way for a LinuxCNC
// machine to run (motion.feed-inhibit, motion.enable, spindle.N.at-speed,
// joint.N.amp-fault-in, halui's program and E-stop pins, a message(9) that
// would fire, ...), each held that way by the resting state of the field
// inputs that decide it through the configuration's HAL logic.
#pragma once

#include "linuxcnc/derive_context.hpp"

namespace lbpkit::linuxcnc::detail {

// Holds each interlock the configuration nets: an input that must read on
// gets a switch held closed, one that must read off nothing (a comment).
void derivePermissives(DeriveContext& c);

}  // namespace lbpkit::linuxcnc::detail
