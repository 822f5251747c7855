// SPDX-License-Identifier: MIT
// HostMot2 general purpose I/O ports (HostMot2 regmap: IOPort). Registers
// (lbpkit/wire/hostmot2_modules.hpp; port p at +4p): data (read: pin
// levels, write: output latch), DDR (1 = output), alternate source (1 = the
// pin's module drives it), open drain, output invert.
#pragma once

#include <array>
#include <cstdint>

#include "hostmot2/module.hpp"

namespace lbpkit::model::hm2 {

class IoPort final : public Module {
 public:
  static constexpr const ModuleKind& kKind = map::kIoPort;
  static constexpr std::uint16_t kData = kKind.address(map::ioport::kData);
  static constexpr std::uint16_t kDdr = kKind.address(map::ioport::kDdr);
  static constexpr std::uint16_t kAltSource = kKind.address(map::ioport::kAltSource);
  static constexpr std::uint16_t kOpenDrain = kKind.address(map::ioport::kOpenDrain);
  static constexpr std::uint16_t kOutputInvert = kKind.address(map::ioport::kOutputInvert);
  static constexpr unsigned kMaxPorts = 4;

  // What an observer sees: per port the pin levels (as the data register
  // reads) and the host-written registers, masked to the port's width.
  struct Port {
    std::uint32_t pins = 0;
    std::uint32_t outputLatch = 0;
    std::uint32_t ddr = 0;
    std::uint32_t altSource = 0;
    std::uint32_t openDrain = 0;
    std::uint32_t outputInvert = 0;
  };
  struct State {
    unsigned ports = 0;  // the first `ports` entries are valid
    unsigned width = 0;
    std::array<Port, kMaxPorts> port{};
  };

  IoPort(unsigned ports, unsigned width) : Module(kKind, kKind.base, ports, kKind.version), ports_(ports), width_(width) {}

  std::uint32_t readRegister(std::uint16_t address, SimTime now) override;
  WriteResult writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) override;
  void reset() override;  // power-up: every register 0, every pin an input

  // The world drives GPIO inputs (default: pulled up).
  void setInput(unsigned port, unsigned bit, bool level);
  // What a pin shows: a GPIO output's level, else the input level.
  [[nodiscard]] bool pin(unsigned port, unsigned bit) const;
  // Watchdog bite: every pin becomes an input (the DDR and the output
  // latch cleared), a module's outputs as well as GPIO's.
  void releaseOutputs();
  // Whether a bite left pin `bit` of `port` an input that no DDR write has
  // made an output again: a module output there (a StepGen's step) drives
  // nothing. A host that never wrote the DDR is taken as having set it, as
  // lbpkit's own host library drives StepGens without it.
  [[nodiscard]] bool released(unsigned port, unsigned bit) const { return (released_.at(port) >> bit) & 1U; }
  [[nodiscard]] std::uint32_t ddr(unsigned port) const { return regs_.at(port)[1]; }
  [[nodiscard]] unsigned ports() const { return ports_; }
  [[nodiscard]] unsigned width() const { return width_; }  // pins per port
  [[nodiscard]] State state() const;

 private:
  [[nodiscard]] std::uint32_t mask() const { return width_ >= 32 ? ~0U : (1U << width_) - 1; }
  unsigned ports_;
  unsigned width_;
  // data, DDR, alternate source, open drain, invert
  std::array<std::array<std::uint32_t, 5>, kMaxPorts> regs_{};
  std::array<std::uint32_t, kMaxPorts> inputs_{~0U, ~0U, ~0U, ~0U};
  std::array<std::uint32_t, kMaxPorts> released_{};  // released(): set by a bite, cleared by DDR writes
};

}  // namespace lbpkit::model::hm2
