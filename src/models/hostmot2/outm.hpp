// SPDX-License-Identifier: MIT
// HostMot2 OutM: plain outputs under their own numbers, so a card's output
// terminals get names of their own in HAL rather than GPIO numbers (the
// 7I96S's OUT4 and OUT5 on TB3: hm2_7i96s.0.outm.00.out-04, -05).
// docs/hostmot2-modules.md#outm; LinuxCNC outm.c (its register map comment
// and hm2_outm_parse_md), hostmot2.9 "OutM Simple output module"; mesaflash
// hostmot2.c ("OutM", pins "Output<n>"; its tag: the module map).
//
// Registers (lbpkit/wire/hostmot2_modules.hpp; instance i at +4i):
//   data   bit n drives the pin whose descriptor says output n
//                 (secondary pin 0x81 + n); 1 = on
// Power-up: every output off. LinuxCNC writes 0 at load and then, every
// servo period, out-NN XOR invert-NN.
#pragma once

#include <array>
#include <cstdint>

#include "hostmot2/module.hpp"

namespace lbpkit::model::hm2 {

class OutM final : public Module {
 public:
  static constexpr const ModuleKind& kKind = map::kOutM;  // outm.c's register map
  static constexpr unsigned kMaxInstances = 8;

  struct State {
    unsigned instances = 0;
    std::array<std::uint32_t, kMaxInstances> data{};
  };

  OutM(std::uint16_t base, unsigned instances, std::uint8_t version = 0);

  std::uint32_t readRegister(std::uint16_t address, SimTime now) override;
  WriteResult writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) override;
  void reset() override { data_.fill(0); }

  // Output n of instance i: on (true) or off.
  [[nodiscard]] bool output(unsigned instance, unsigned n) const { return ((data_.at(instance) >> n) & 1U) != 0; }
  [[nodiscard]] State state() const { return State{instances_, data_}; }

 private:
  std::array<std::uint32_t, kMaxInstances> data_{};
};

}  // namespace lbpkit::model::hm2
