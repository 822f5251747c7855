// SPDX-License-Identifier: MIT
// HostMot2 MuxedQCountSel: the ENCMUX select line that multiplexes the
// 7I77's six encoders onto three pin groups (manual: P1 HOST INTERFACE;
// docs/protocol-facts.md#muxed-encoders). A module with pins in the IDROM but
// no registers: the muxed counters (muxed_encoder.hpp) do the sampling.
#pragma once

#include "hostmot2/module.hpp"

namespace lbpkit::model::hm2 {

class MuxedEncoderSelect final : public Module {
 public:
  static constexpr const ModuleKind& kKind = map::kMuxedQCountSel;
  MuxedEncoderSelect() : Module(kKind, kKind.base, 1, kKind.version) {}
  std::uint32_t readRegister(std::uint16_t, SimTime) override { return 0; }
  WriteResult writeRegister(std::uint16_t, std::uint32_t, SimTime) override { return WriteResult::Unmapped; }
  void reset() override {}
};

}  // namespace lbpkit::model::hm2
