// SPDX-License-Identifier: MIT
// HostMot2 InM: filtered inputs read straight from FPGA pins, each with a
// short or a long debounce time, plus four small MPG counters on inputs
// 0..7 (the 7I96S's isolated inputs IN0..IN10 on TB3:
// hm2_7i96s.0.inm.00.input-00..10).
// docs/hostmot2-modules.md#inm; LinuxCNC inm.c (its register map comment,
// hm2_inm_parse_md, hm2_inm_write), hostmot2.9 "inm and inmux"; mesaflash
// hostmot2.c (tag 0x23 "InM", pins "Input<n>").
//
// Registers (lbpkit/wire/hostmot2_modules.hpp; instance i at +4i; ClockLow):
//   control   4..0 MaxBit (ro): inputs scanned - 1; 5 invert every
//                    input; 15..6 rate divisor; 21..16 short time, 31..22
//                    long time, in scans. One input is sampled every
//                    4 * (divisor + 1) ClockLow ticks, so each input every
//                    MaxBit + 1 times that (LinuxCNC: 20 kHz per input, 5
//                    and 500 scans, invert set "as this matches all existing
//                    hardware")
//   filter    bit n: input n uses the long time (input-NN-slow)
//   filtered  the inputs after the debounce filter (ro)
//   raw       the inputs as sampled (ro)
//   MPG       read: four 8-bit counters, byte k counting the
//                    quadrature of filtered inputs 2k (A) and 2k+1 (B);
//                    write: bit 0 of byte k, 1 = 4X, 0 = 1X
//
// The pins are the card's: the world drives them through the IOPort (a
// 7I96S's input terminal, when energized, pulls its FPGA pin low; with the
// invert bit the registers then read 1). The card connects each input to the
// I/O pin its pin descriptor names.
#pragma once

#include <array>
#include <cstdint>

#include "hostmot2/ioport.hpp"
#include "hostmot2/module.hpp"

namespace lbpkit::model::hm2 {

class InM final : public Module {
 public:
  static constexpr const ModuleKind& kKind = map::kInM;  // inm.c's register map
  static constexpr unsigned kMaxInstances = 2;
  static constexpr unsigned kMaxInputs = 32;
  static constexpr unsigned kMpgs = 4;
  using enum map::inm::Register;
  static constexpr std::uint32_t kMaxBitMask = 0x1F;
  static constexpr std::uint32_t kInvert = 1U << 5;

  struct State {
    struct Instance {
      unsigned inputs = 0;
      std::uint32_t control = 0, filter = 0, filtered = 0, raw = 0, mpgMode = 0;
      std::array<std::uint8_t, kMpgs> mpg{};
    };
    unsigned instances = 0;
    std::array<Instance, kMaxInstances> instance{};
  };

  // `inputs` per instance (1..32: MaxBit + 1).
  InM(std::uint16_t base, unsigned instances, unsigned inputs, std::uint32_t clockLow, std::uint8_t version = 0);

  // Input `input` of `instance` reads I/O pin `bit` of `port` of `io`.
  // Inputs left unconnected read high, as an idle input's pin does.
  void connect(const IoPort* io, unsigned instance, unsigned input, unsigned port, unsigned bit);

  std::uint32_t readRegister(std::uint16_t address, SimTime now) override;
  WriteResult writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) override;
  // Debounces what the pins show: an input whose level differs from its
  // filtered state takes it once it has kept that level for its filter
  // time (short or long scans); the MPG counters follow inputs 0..7.
  void advance(SimTime now) override;
  void reset() override;  // registers 0 (no invert, divisor 0, times 0), counters 0, filtered = the pins

  [[nodiscard]] bool input(unsigned instance, unsigned n) const { return ((filtered_.at(instance) >> n) & 1U) != 0; }
  [[nodiscard]] bool rawInput(unsigned instance, unsigned n) const { return ((raw(instance) >> n) & 1U) != 0; }
  [[nodiscard]] std::uint8_t mpgCount(unsigned instance, unsigned k) const { return mpg_.at(instance).at(k); }
  // How long an input must keep a new level: scans * 4 * (divisor + 1) *
  // (MaxBit + 1) ClockLow ticks.
  [[nodiscard]] SimTime filterTime(unsigned instance, unsigned n) const;
  [[nodiscard]] unsigned inputs() const { return inputs_; }
  [[nodiscard]] State state() const;

 private:
  struct Source {
    const IoPort* io = nullptr;
    std::uint8_t port = 0, bit = 0;
  };
  [[nodiscard]] std::uint32_t raw(unsigned instance) const;
  [[nodiscard]] std::uint32_t mask() const { return inputs_ >= 32 ? ~0U : (1U << inputs_) - 1; }
  void step(unsigned instance, unsigned input);  // input just changed its filtered state

  unsigned inputs_;
  std::uint32_t clock_;
  std::array<std::array<Source, kMaxInputs>, kMaxInstances> source_{};
  std::array<std::uint32_t, kMaxInstances> control_{}, filter_{}, mpgMode_{}, filtered_{};
  // Inputs whose pin differs from their filtered state, and since when.
  std::array<std::uint32_t, kMaxInstances> pending_{};
  std::array<std::array<SimTime, kMaxInputs>, kMaxInstances> since_{};
  std::array<std::array<std::uint8_t, kMpgs>, kMaxInstances> mpg_{};
  SimTime now_{};
};

}  // namespace lbpkit::model::hm2
