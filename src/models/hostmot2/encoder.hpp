// SPDX-License-Identifier: MIT
// HostMot2 QCount: plain (non-muxed) quadrature counters, one pin group per
// encoder (docs/hostmot2-modules.md#qcount-plain-encoder; firmware qcountersf.vhd,
// qcounterate.vhd, IDROMConst.vhd; LinuxCNC encoder.c). The registers and
// counting are the muxed counters' (muxed_encoder.hpp), at their own base
// (lbpkit/wire/hostmot2_modules.hpp), but for the rate register: filter
// rate, 11..0: the inputs are sampled every rate+2 ClockLow ticks
// (power-up: round(ClockLow / 16 MHz) - 2; LinuxCNC writes ClockLow /
// 25 MHz - 2)
// and the digital filter wants a new state to last 3 samples (15 with the
// CCR's filter bit) rather than the muxed counters' 2 (8).
#pragma once

#include "hostmot2/muxed_encoder.hpp"

namespace lbpkit::model::hm2 {

class Encoder final : public MuxedEncoder {
 public:
  static constexpr const ModuleKind& kKind = map::kQCount;
  static constexpr std::uint16_t kDefaultBase = kKind.base;

  Encoder(std::uint16_t base, unsigned instances, std::uint32_t clockLow, std::uint8_t version = kKind.version)
      : MuxedEncoder(instances, clockLow, Variant{&kKind, base, version, 1, 16'000'000, {3, 15}}) {}
};

}  // namespace lbpkit::model::hm2
