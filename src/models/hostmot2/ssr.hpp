// SPDX-License-Identifier: MIT
// HostMot2 SSR (XfrmrOut): isolated solid-state relay outputs, each a MOSFET
// switch whose gate the FPGA drives through a transformer and rectifier, so
// a switch closes only while the module's drive clock runs (the 7I96S's
// OUT0..OUT3 on TB3: hm2_7i96s.0.ssr.00.out-00..03).
// docs/hostmot2-modules.md#ssr; LinuxCNC ssr.c (its register map comment,
// hm2_ssr_parse_md, hm2_ssr_compute_rate_regs), hostmot2.9 "Solid State
// Relay"; mesaflash hostmot2.c ("SSR", pins "Out-NN", "AC Ref"; its tag:
// the module map).
//
// Registers (lbpkit/wire/hostmot2_modules.hpp; instance i at +4i; ClockLow):
//   data   bit n: output n (pin 0x81 + n) closed when 1
//   rate   11..0 divisor: the drive runs at ClockLow / (divisor + 2)
//          / 2 (LinuxCNC: 1 MHz by default, 25 kHz..25 MHz);
//          12 enable. 0 (power-up, or LinuxCNC's rate pin 0) stops
//          the drive: every switch open whatever the data says.
#pragma once

#include <array>
#include <cstdint>

#include "hostmot2/module.hpp"

namespace lbpkit::model::hm2 {

class Ssr final : public Module {
 public:
  static constexpr const ModuleKind& kKind = map::kSsr;  // ssr.c's register map
  static constexpr unsigned kMaxInstances = 8;
  using enum map::ssr::Register;
  static constexpr std::uint32_t kDivisorMask = 0xFFF;
  static constexpr std::uint32_t kEnable = 1U << 12;

  struct State {
    unsigned instances = 0;
    std::array<std::uint32_t, kMaxInstances> data{};
    std::array<std::uint32_t, kMaxInstances> rate{};
  };

  Ssr(std::uint16_t base, unsigned instances, std::uint32_t clockLow, std::uint8_t version = 0);

  std::uint32_t readRegister(std::uint16_t address, SimTime now) override;
  WriteResult writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) override;
  void reset() override;  // every switch open, the drive stopped

  // Is switch n of instance i closed? Only while the drive runs.
  [[nodiscard]] bool closed(unsigned instance, unsigned n) const;
  [[nodiscard]] bool driving(unsigned instance) const { return (rate_.at(instance) & kEnable) != 0; }
  // The drive frequency (Hz); 0 when stopped.
  [[nodiscard]] double driveFrequency(unsigned instance) const;
  [[nodiscard]] State state() const { return State{instances_, data_, rate_}; }

 private:
  std::uint32_t clock_;
  std::array<std::uint32_t, kMaxInstances> data_{};
  std::array<std::uint32_t, kMaxInstances> rate_{};
};

}  // namespace lbpkit::model::hm2
