// HostMot2 general purpose I/O ports (HostMot2 regmap: IOPort).
//   0x1000 data (read: pin levels, write: output latch)   0x1100 DDR (1 = output)
//   0x1200 alternate source (1 = the pin's module drives it)
//   0x1300 open drain   0x1400 output invert       (port p at +4p)
#pragma once

#include <array>
#include <cstdint>

#include "hostmot2/module.hpp"

namespace hm2 {

class IoPort final : public Module {
 public:
  static constexpr std::uint16_t kData = 0x1000;
  static constexpr std::uint16_t kDdr = 0x1100;
  static constexpr std::uint16_t kAltSource = 0x1200;
  static constexpr std::uint16_t kOpenDrain = 0x1300;
  static constexpr std::uint16_t kOutputInvert = 0x1400;
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

  IoPort(unsigned ports, unsigned width) : ports_(ports), width_(width) {}

  [[nodiscard]] std::string_view name() const override { return "IOPort"; }
  [[nodiscard]] ModuleDescriptor descriptor() const override {
    return ModuleDescriptor{tag::kIoPort, 0, kClockLow, static_cast<std::uint8_t>(ports_), kData, 5, 0, 0x1F};
  }
  [[nodiscard]] bool decodes(std::uint16_t a) const override {
    return a >= kData && a < kOutputInvert + kRegisterStride && (a & 0xFFU) < ports_ * 4;
  }
  std::uint32_t read(std::uint16_t address, SimTime now) override;
  WriteResult write(std::uint16_t address, std::uint32_t value, SimTime now) override;
  void reset() override;  // power-up: every register 0, every pin an input

  // The world drives GPIO inputs (default: pulled up).
  void setInput(unsigned port, unsigned bit, bool level);
  // What a pin shows: a GPIO output's level, else the input level.
  [[nodiscard]] bool pin(unsigned port, unsigned bit) const;
  // Watchdog bite: every GPIO output is released.
  void releaseOutputs();
  [[nodiscard]] std::uint32_t ddr(unsigned port) const { return regs_.at(port)[1]; }
  [[nodiscard]] State state() const;

 private:
  [[nodiscard]] std::uint32_t mask() const { return width_ >= 32 ? ~0U : (1U << width_) - 1; }
  unsigned ports_;
  unsigned width_;
  // data, DDR, alternate source, open drain, invert
  std::array<std::array<std::uint32_t, 5>, kMaxPorts> regs_{};
  std::array<std::uint32_t, kMaxPorts> inputs_{~0U, ~0U, ~0U, ~0U};
};

}  // namespace hm2
