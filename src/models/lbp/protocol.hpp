// SPDX-License-Identifier: MIT
// The LBP facts the models share with the host (lbpkit_wire), seen from the
// models' own `lbp` namespace, so a model says lbp::local_read::kStatus.
#pragma once

#include "lbpkit/wire/crc8.hpp"
#include "lbpkit/wire/lbp.hpp"
#include "lbpkit/wire/process_data.hpp"

namespace lbp {
using namespace lbpkit::wire::lbp;
}  // namespace lbp
