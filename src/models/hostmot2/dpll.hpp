// SPDX-License-Identifier: MIT
// HostMot2 HM2DPLL: a phase-locked loop that locks a 42-bit phase
// accumulator to the host's reads of its sync register, and four timers
// that fire at set phases of it (docs/hostmot2-modules.md#dpll; firmware
// hmtimers.vhd, IDROMConst.vhd; LinuxCNC dpll.c). StepGens and encoders
// sample their position on a timer's rising edge when their timer-number
// register selects it (lastRisingEdge()).
//
// Registers (lbpkit/wire/hostmot2_modules.hpp; one instance; ClockLow):
//   base rate    added to the accumulator every `prescale` ClockLow
//                      ticks (less the loop's correction)
//   phase         read: the accumulator's top 32 bits; write: loads them
//   control 0    write: 31..24 prescale, 23..0 phase error limit
//                      (also clears the loop filter); read: 31..24
//                      prescale, 23..0 the correction being applied
//   control 1    31..16 filter prescale (time constant); read 7..0:
//                      the accumulator size, 42 (LinuxCNC's "ddsize")
//   timers 1/2  15..0 timer 1, 31..16 timer 2: phase offsets
//   timers 3/4  15..0 timer 3, 31..16 timer 4
//   sync          read or write: the phase error is taken now; a read
//                      returns the accumulator's top 32 bits
// Rate source 0 is the reference (rising as the accumulator wraps through
// zero), 1..4 the timers (rising when the accumulator's top 16 bits plus
// the timer's offset wrap through zero).
#pragma once

#include <array>
#include <cstdint>
#include <optional>

#include "hostmot2/module.hpp"

namespace lbpkit::model::hm2 {

class Dpll final : public Module {
 public:
  static constexpr const ModuleKind& kKind = map::kDpll;
  static constexpr unsigned kAccumulatorBits = map::dpll::kAccumulatorBits;  // control 1 bits 7..0
  static constexpr unsigned kRateSources = 5;       // reference + timers 1..4
  using enum map::dpll::Register;

  // What an observer sees.
  struct State {
    std::uint32_t baseRate = 0;
    std::uint32_t phase = 0;       // the accumulator's top 32 bits
    std::uint32_t phaseError = 0;  // as last taken by a sync access
    std::uint8_t prescale = 0;
    std::uint32_t phaseLimit = 0;
    std::uint16_t filterPrescale = 0;
    std::int32_t correction = 0;
    std::array<std::uint16_t, 4> timer{};
  };

  Dpll(std::uint16_t base, unsigned instances, std::uint32_t clockLow, std::uint8_t version = 0);

  std::uint32_t readRegister(std::uint16_t address, SimTime now) override;
  WriteResult writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) override;
  void advance(SimTime now) override;
  void reset() override;

  // The ClockLow tick of the last rising edge of rate source `source` (0:
  // reference, 1..4: timer) at or before `now`; none while the loop does not
  // run (base rate 0) or before the first edge. Worked out at the rate the
  // accumulator runs at now.
  [[nodiscard]] std::optional<std::uint64_t> lastRisingEdge(unsigned source, SimTime now);
  [[nodiscard]] std::uint32_t clock() const { return clock_; }
  [[nodiscard]] State state() const;

 private:
  static constexpr std::uint64_t kMask = (std::uint64_t{1} << kAccumulatorBits) - 1;
  [[nodiscard]] std::uint32_t phaseTop() const { return static_cast<std::uint32_t>(accum_ >> (kAccumulatorBits - 32)); }
  [[nodiscard]] std::int32_t correction() const;
  [[nodiscard]] unsigned prescaleTicks() const { return prescale_ == 0 ? 256U : prescale_; }
  [[nodiscard]] unsigned filterAdds() const { return filterPrescale_ == 0 ? 65536U : filterPrescale_; }
  void takePhaseError();
  void runAdds(std::uint64_t adds);

  std::uint32_t clock_;
  // Simulated state: ticks done, the accumulator, the prescaler and the filter.
  std::uint64_t tick_ = 0;
  std::uint64_t nextAddTick_ = 1;
  std::uint64_t lastAddTick_ = 0;
  unsigned addsToFilter_ = 1;
  std::uint64_t accum_ = 0;  // kAccumulatorBits wide
  std::uint32_t baseRate_ = 0;
  std::uint32_t phaseError_ = 0;
  std::int32_t bounded_ = 0;   // the phase error, limited (24 bits)
  std::int32_t filtered_ = 0;  // its low-pass filtered value (24 bits)
  std::uint8_t prescale_ = 0;
  std::int32_t phaseLimit_ = 0;
  std::uint16_t filterPrescale_ = 0;
  std::array<std::uint16_t, 4> timer_{};
};

}  // namespace lbpkit::model::hm2
