// SPDX-License-Identifier: MIT
// HostMot2 StepGen: step/dir pulse generators (docs/hostmot2-modules.md#stepgen;
// firmware kubstepgenz.vhd, hostmot2.vhd, IDROMConst.vhd; LinuxCNC stepgen.c).
//
// Registers (lbpkit/wire/hostmot2_modules.hpp; instance i at +4i unless
// single; ClockLow):
//   rate                signed 32 bits, added to the 48-bit accumulator every
//                        ClockLow tick: steps/s = rate * ClockLow / 2^32
//   accumulator          read: accumulator bits 47..16 (16.16 steps, or as
//                        latched on the DPLL timer); write: loads them, no step
//   mode                 1..0 step type (0 step/dir, 1 up/down, 2 quadrature,
//                        3 table); 2 swap step and dir (versions 0x42, 0xC2);
//                        7..4 index/probe latch control (version 0xC2)
//   dir setup            13..0 ClockLow ticks from a direction change to the next step
//   dir hold             13..0 ticks from a step to a direction change
//   pulse width          13..0 ticks the step output is high (plus one)
//   pulse idle           13..0 ticks low before the next step may start
//   table data           each write shifts one pattern into the step table
//   table length         3..0 the table's last index; a write restarts it
//   master rate          single: the prescaler's DDS (LinuxCNC writes 0xFFFFFFFF)
//   timer select         single: 15 enable, 14..12 DPLL rate source whose
//                        rising edge latches every accumulator (LinuxCNC's
//                        stepgen.timer-number; written only when a DPLL exists)
// A step happens when the accumulator's bit 31 carries into (or borrows
// from) bit 32. While a pulse, its idle time, a direction setup or hold, or
// a pending direction change runs, the add that would step waits, as
// kubstepgenz.vhd's ddshold does: the rate is exact as long as the steps
// fit the timings, and limited to one step per their sum otherwise.
#pragma once

#include <array>
#include <cstdint>

#include "hostmot2/module.hpp"

namespace lbpkit::model::hm2 {

class Dpll;

class StepGen final : public Module {
 public:
  static constexpr const ModuleKind& kKind = map::kStepGen;
  static constexpr unsigned kMaxInstances = 16;
  // The IDROM and LinuxCNC count 10; the timer select is one past them.
  using enum map::stepgen::Register;
  static constexpr std::uint32_t kTimerEnable = 1U << 15;
  static constexpr std::uint32_t kSwapStepDir = 1U << 2;

  // The levels of one StepGen's outputs (output 0 is the IDROM's step pin
  // 0x81, output 1 the dir pin 0x82, the rest table pins).
  struct Pins {
    bool step = false;
    bool dir = false;
    std::uint32_t outputs = 0;
  };
  struct State {
    struct Channel {
      std::uint32_t rate = 0;
      std::uint32_t accumulator = 0;  // as the register reads now
      std::uint32_t mode = 0;
      std::int64_t steps = 0;
      Pins pins;
    };
    unsigned instances = 0;
    std::uint32_t masterRate = 0;
    std::uint32_t timerSelect = 0;
    std::array<Channel, kMaxInstances> channel{};
  };

  StepGen(std::uint16_t base, unsigned instances, std::uint32_t clockLow, std::uint8_t version = 2);

  std::uint32_t readRegister(std::uint16_t address, SimTime now) override;
  WriteResult writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) override;
  void advance(SimTime now) override;
  void reset() override;  // every register 0, no steps; the step count the machine saw stays

  // Where the timer select register's rate sources come from (the card's
  // DPLL, if its firmware has one). Without one, the select is stored and
  // the accumulator reads live.
  void attachDpll(Dpll* dpll) { dpll_ = dpll; }

  // For the machine: steps made since construction (up minus down, as the
  // step/dir pins showed them) and the pin levels, at `now`.
  [[nodiscard]] std::int64_t steps(unsigned n, SimTime now);
  [[nodiscard]] Pins pins(unsigned n, SimTime now);
  // The commanded rate in steps per second (rate register * ClockLow / 2^32).
  [[nodiscard]] double stepRate(unsigned n) const;
  [[nodiscard]] State state(SimTime now);

 private:
  struct Channel {
    std::uint32_t rate = 0;
    std::uint64_t accum = 0;  // 48 bits
    std::uint32_t mode = 0;
    std::uint16_t dirSetup = 0, dirHold = 0, pulseWidth = 0, pulseIdle = 0;
    std::uint8_t tableLast = 0;
    std::array<std::uint32_t, 16> table{};  // [0]: the pattern written last
    bool dirOut = false;                    // the direction output
    // Ticks (ClockLow edges) of the timing state machine.
    std::uint64_t stepAt = 0;        // the last step pulse rose here (0: none yet)
    std::uint64_t stepHighTo = 0;    // and is high through here
    std::uint64_t pulseFreeAt = 0;   // the earliest add that may step, for the pulse
    std::uint64_t setupFreeAt = 0;   // and for a direction setup
    std::uint64_t dirFreeAt = 0;     // the earliest direction change (hold)
    std::int64_t steps = 0;
    std::int64_t tableOrigin = 0;  // steps when the table restarted
    std::uint32_t latched = 0;     // the accumulator register at the last timer edge
  };
  [[nodiscard]] bool supportsSwap() const { return (version_ & 0x40U) != 0; }
  [[nodiscard]] bool supportsIndex() const { return (version_ & 0x80U) != 0; }
  [[nodiscard]] std::uint32_t modeMask() const;
  // Processes ClockLow edges tick_+1 .. to for every channel.
  void runTo(std::uint64_t to);
  void run(Channel& c, std::uint64_t to) const;
  void step(Channel& c, std::uint64_t crossing, bool up) const;
  // Steps at a constant rate after a step, worked out at once.
  void runSteady(Channel& c, std::uint64_t& t, std::uint64_t to) const;
  [[nodiscard]] Pins pinsOf(const Channel& c) const;

  std::uint32_t clock_;
  std::uint64_t tick_ = 0;  // edges processed
  std::uint32_t masterRate_ = 0;
  std::uint32_t timerSelect_ = 0;
  std::uint64_t lastLatch_ = 0;  // the timer edge latched last
  Dpll* dpll_ = nullptr;
  std::array<Channel, kMaxInstances> ch_{};
};

}  // namespace lbpkit::model::hm2
