// SPDX-License-Identifier: MIT
// StepGen 0 of a card on the host library, set up and commanded as LinuxCNC's
// hostmot2 stepgen does (docs/hostmot2-modules.md#stepgen): step timing in
// ClockLow ticks, the prescaler's DDS at full rate, then the rate register
// (steps/s = rate x ClockLow / 2^32). For the tests that drive a stepper axis
// through `lbpkit sim`.
#pragma once

#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "lbpkit/hostmot2.hpp"
#include "lbpkit/transport.hpp"
#include "lbpkit/wire/hostmot2_modules.hpp"

namespace testing_stepgen {

class StepGenRegisters {
 public:
  using enum lbpkit::wire::hm2::stepgen::Register;

  // Throws std::runtime_error when the firmware has no StepGen.
  StepGenRegisters(lbpkit::Transport& transport, const lbpkit::CardInfo& info) : t_(transport) {
    for (const auto& m : info.modules)
      if (m.tag == lbpkit::wire::hm2::tag::kStepGen) {
        base_ = m.baseAddress;
        stride_ = m.registerStride;
        clockHz_ = m.clockHz;
      }
    if (base_ == 0) throw std::runtime_error("the firmware has no StepGen");
    // 1 us step pulse and space, 10 us direction setup and hold at 100 MHz.
    write(kPulseWidth, 100);
    write(kPulseIdle, 100);
    write(kDirSetup, 1000);
    write(kDirHold, 1000);
    write(kMasterRate, 0xFFFFFFFFU);
  }
  // StepGen 0's commanded rate, signed. Throws lbpkit::Error when the card
  // does not answer.
  void setRate(double stepsPerSecond) {
    const double r = std::round(stepsPerSecond * 4294967296.0 / clockHz_);
    write(kRate, static_cast<std::uint32_t>(static_cast<std::int32_t>(r)));
  }

 private:
  void write(unsigned reg, std::uint32_t value) {
    t_.write32(static_cast<std::uint16_t>(base_ + reg * stride_), value);  // instance 0
  }
  lbpkit::Transport& t_;
  std::uint16_t base_ = 0;
  std::uint32_t stride_ = 0x100;
  double clockHz_ = 1e8;
};

}  // namespace testing_stepgen
