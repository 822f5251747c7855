// SPDX-License-Identifier: MIT
// A configuration's spindle: the 7I77 analog output no joint drives
// (analogout5 and ENA5 first) or the 7I76's SpinOut, its rpm at 10 V from
// hostmot2's scalemax (or [SPINDLE_0]OUTPUT_SCALE), and the encoder on the
// spindle's feedback (spindle.0.revs, speed-in, index-enable; motion.spindle-*
// in LinuxCNC 2.7) that no joint reads.
#pragma once

#include "linuxcnc/derive_context.hpp"

namespace lbpkit::linuxcnc::detail {

// The machine file's [spindle], into c.out.spindle (nothing when the
// configuration drives none).
void deriveSpindle(DeriveContext& c);

}  // namespace lbpkit::linuxcnc::detail
