// SPDX-License-Identifier: MIT
// Simulated time shared by every device model.
//
// Models never read a wall clock: they are told what time it is. Only the
// daemons (`lbpkit remote`, `lbpkit sim`) tie simulated time to real time, so
// a test of a 50 ms watchdog runs in microseconds.
#pragma once

#include <chrono>
#include <cstdint>

#include "lbp/protocol.hpp"

namespace lbpkit::model::lbp {

using SimTime = std::chrono::duration<std::int64_t, std::nano>;

constexpr SimTime characterTime(std::uint32_t baud) {
  return SimTime{static_cast<std::int64_t>(1'000'000'000LL * kBitsPerCharacter / (baud ? baud : 1))};
}

}  // namespace lbpkit::model::lbp
