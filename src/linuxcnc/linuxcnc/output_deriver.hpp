// SPDX-License-Identifier: MIT
// A configuration's field outputs: each 7I77 or 7I76 output-NN a HAL net
// drives, named after its signal, as a machine file's [[output]].
#pragma once

#include "linuxcnc/derive_context.hpp"

namespace lbpkit::linuxcnc::detail {

// Every field output a net drives, once: an output on two signals (a
// second `net` after an `unlinkp`, two files naming it) is one output
// whose comment names each.
void deriveOutputs(DeriveContext& c);

}  // namespace lbpkit::linuxcnc::detail
