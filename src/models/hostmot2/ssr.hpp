// HostMot2 SSR (XfrmrOut): isolated solid-state relay outputs, each a MOSFET
// switch whose gate the FPGA drives through a transformer and rectifier, so
// a switch closes only while the module's drive clock runs (the 7I96S's
// OUT0..OUT3 on TB3: hm2_7i96s.0.ssr.00.out-00..03).
// docs/hostmot2-modules.md#ssr; LinuxCNC ssr.c (its register map comment,
// hm2_ssr_parse_md, hm2_ssr_compute_rate_regs), hostmot2.9 "Solid State
// Relay"; mesaflash hostmot2.c (tag 0xC3 "SSR", pins "Out-NN", "AC Ref").
//
// Registers (instance i at +4i; ClockLow):
//   0x7D00 data   bit n: output n (pin 0x81 + n) closed when 1
//   0x7E00 rate   11..0 divisor: the drive runs at ClockLow / (divisor + 2)
//                 / 2 (LinuxCNC: 1 MHz by default, 25 kHz..25 MHz);
//                 12 enable. 0 (power-up, or LinuxCNC's rate pin 0) stops
//                 the drive: every switch open whatever the data says.
#pragma once

#include <array>
#include <cstdint>

#include "hostmot2/module.hpp"

namespace hm2 {

class Ssr final : public Module {
 public:
  static constexpr std::uint8_t kTag = 0xC3;  // hostmot2.h HM2_GTAG_SSR (195); mesaflash HM2_GTAG_SSR
  static constexpr std::uint16_t kDefaultBase = 0x7D00;  // ssr.c register map
  static constexpr unsigned kRegisters = 2;
  static constexpr unsigned kMaxInstances = 8;
  enum Register : unsigned { kData, kRate };
  static constexpr std::uint32_t kDivisorMask = 0xFFF;
  static constexpr std::uint32_t kEnable = 1U << 12;

  struct State {
    unsigned instances = 0;
    std::array<std::uint32_t, kMaxInstances> data{};
    std::array<std::uint32_t, kMaxInstances> rate{};
  };

  Ssr(std::uint16_t base, unsigned instances, std::uint32_t clockLow, std::uint8_t version = 0);

  [[nodiscard]] std::string_view name() const override { return "SSR"; }
  [[nodiscard]] ModuleDescriptor descriptor() const override {
    return ModuleDescriptor{kTag, version_, kClockLow, static_cast<std::uint8_t>(instances_), base_, kRegisters, 0, 0x3};
  }
  [[nodiscard]] bool decodes(std::uint16_t a) const override;
  std::uint32_t read(std::uint16_t address, SimTime now) override;
  WriteResult write(std::uint16_t address, std::uint32_t value, SimTime now) override;
  void reset() override;  // every switch open, the drive stopped

  // Is switch n of instance i closed? Only while the drive runs.
  [[nodiscard]] bool closed(unsigned instance, unsigned n) const;
  [[nodiscard]] bool driving(unsigned instance) const { return (rate_.at(instance) & kEnable) != 0; }
  // The drive frequency (Hz); 0 when stopped.
  [[nodiscard]] double driveFrequency(unsigned instance) const;
  [[nodiscard]] unsigned instances() const { return instances_; }
  [[nodiscard]] State state() const { return State{instances_, data_, rate_}; }

 private:
  std::uint16_t base_;
  unsigned instances_;
  std::uint32_t clock_;
  std::uint8_t version_;
  std::array<std::uint32_t, kMaxInstances> data_{};
  std::array<std::uint32_t, kMaxInstances> rate_{};
};

}  // namespace hm2
