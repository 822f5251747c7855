// SPDX-License-Identifier: MIT
// HostMot2 PWMGen: PWM/PDM generators with direction and /enable outputs
// (docs/hostmot2-modules.md#pwmgen; firmware pwmpdmgenh.vhd, pwmrefh.vhd,
// hostmot2.vhd, IDROMConst.vhd; LinuxCNC pwmgen.c).
//
// Registers (lbpkit/wire/hostmot2_modules.hpp; instance i at +4i unless
// single; ClockHigh):
//   value              31 direction, 27..16 the 12-bit PWM/PDM value
//   mode               1..0 PWM width (9, 10, 11, 12 bits), 2 symmetrical
//                       (up/down count), 4..3 output mode (0 PWM/dir, 1
//                       dir/PWM, 2 up/down, 3 PDM/dir), 5 double buffered
//   PWM rate        single, 16 bits: the PWM counter counts at
//                       ClockHigh * rate / 65536
//   PDM rate        single, 16 bits: PDM pulses at ClockHigh * rate / 65536
//   enable           single: bit i enables instance i (its /enable pin,
//                       0x83, is the inverse)
// The duty cycle is value / 2^width for PWM (1 from 2^width on) and
// value / 4096 for PDM. The PWM and direction pins run whether or not the
// enable bit is set; only the /enable pin follows it.
#pragma once

#include <array>
#include <cstdint>

#include "hostmot2/module.hpp"

namespace lbpkit::model::hm2 {

class PwmGen final : public Module {
 public:
  static constexpr const ModuleKind& kKind = map::kPwmGen;
  static constexpr unsigned kMaxInstances = 32;  // one enable bit each
  using enum map::pwmgen::Register;
  enum class OutputMode : std::uint8_t { PwmDir = 0, DirPwm = 1, UpDown = 2, PdmDir = 3 };
  static constexpr std::uint32_t kDirection = 1U << 31;
  static constexpr std::uint32_t kSymmetrical = 1U << 2;
  static constexpr std::uint32_t kDoubleBuffered = 1U << 5;

  // What the machine sees of one PWMGen (a VFD's analog input filters the
  // PWM to its average: the duty cycle).
  struct Output {
    double duty = 0.0;  // 0..1 of the PWM (or PDM) output's time high
    bool direction = false;
    bool enabled = false;  // the enable bit (the /enable pin low)
    OutputMode mode = OutputMode::PwmDir;
  };
  struct State {
    unsigned instances = 0;
    std::uint32_t pwmRate = 0, pdmRate = 0, enable = 0;
    std::array<std::uint32_t, kMaxInstances> value{};
    std::array<std::uint32_t, kMaxInstances> mode{};
  };

  PwmGen(std::uint16_t base, unsigned instances, std::uint32_t clockHigh, std::uint8_t version = 0);

  std::uint32_t readRegister(std::uint16_t address, SimTime now) override;
  WriteResult writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) override;
  void reset() override;  // every register 0: duty 0, disabled

  [[nodiscard]] Output output(unsigned n) const;
  [[nodiscard]] double duty(unsigned n) const { return output(n).duty; }
  // The PWM repetition rate (Hz) instance n runs at: ClockHigh * rate /
  // 65536 / 2^width, halved when symmetrical; for PDM, the pulse clock.
  [[nodiscard]] double frequency(unsigned n) const;
  [[nodiscard]] State state() const;

 private:
  std::uint32_t clock_;
  std::uint32_t pwmRate_ = 0, pdmRate_ = 0, enable_ = 0;
  std::array<std::uint32_t, kMaxInstances> value_{};
  std::array<std::uint32_t, kMaxInstances> mode_{};
};

}  // namespace lbpkit::model::hm2
