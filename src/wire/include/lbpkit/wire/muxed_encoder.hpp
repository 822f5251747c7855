// SPDX-License-Identifier: MIT
// HostMot2's muxed quadrature counter (MuxedQCount): its CCR bits
// (docs/protocol-facts.md#muxed-encoders; firmware: qcounterate.vhd,
// qcounter.vhd; LinuxCNC: hostmot2/encoder.c). The registers:
// hostmot2_modules.hpp.
#pragma once

#include <cstdint>

#include "lbpkit/wire/hostmot2_modules.hpp"

namespace lbpkit::wire::qcount {

// The registers (counter n at +4n in each): the module map's.
namespace reg = hm2::qcount;

// Counter control register (CCR) bits.
namespace ccr {
inline constexpr unsigned kLatchedShift = 16;        // 31..16: count latched on index (ro)
inline constexpr std::uint32_t kQuadError = 1U << 15;
inline constexpr std::uint32_t kAbMaskPolarity = 1U << 14;
inline constexpr std::uint32_t kFilter = 1U << 11;    // 1: 15 ticks, 0: 3
inline constexpr std::uint32_t kCounterMode = 1U << 10;  // up/down
inline constexpr std::uint32_t kUseIndexMask = 1U << 9;
inline constexpr std::uint32_t kIndexMaskPolarity = 1U << 8;
inline constexpr std::uint32_t kGateIndex = 1U << 7;
inline constexpr std::uint32_t kJustOnce = 1U << 6;
inline constexpr std::uint32_t kClearOnIndex = 1U << 5;
inline constexpr std::uint32_t kLatchOnIndex = 1U << 4;
inline constexpr std::uint32_t kIndexPolarity = 1U << 3;
inline constexpr std::uint32_t kInputZ = 1U << 2;  // filtered inputs (ro)
inline constexpr std::uint32_t kInputB = 1U << 1;
inline constexpr std::uint32_t kInputA = 1U << 0;
}  // namespace ccr

}  // namespace lbpkit::wire::qcount
