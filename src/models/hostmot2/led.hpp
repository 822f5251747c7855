// SPDX-License-Identifier: MIT
// HostMot2 LED module (HostMot2 regmap: LED; docs/protocol-facts.md#module-tags):
// one write-only register (lbpkit/wire/hostmot2_modules.hpp); the card's
// LEDs take its top `count` bits (CR1..CR4 on a 7I92).
#pragma once

#include <cstdint>

#include "hostmot2/module.hpp"

namespace lbpkit::model::hm2 {

class Led final : public Module {
 public:
  static constexpr const ModuleKind& kKind = map::kLed;
  static constexpr std::uint16_t kLeds = kKind.address(map::led::kLeds);
  struct State {
    unsigned count = 0;
    std::uint32_t leds = 0;  // as leds() gives them
  };
  explicit Led(unsigned count) : Module(kKind, kKind.base, 1, kKind.version), count_(count) {}
  std::uint32_t readRegister(std::uint16_t, SimTime) override { return 0; }  // write only
  WriteResult writeRegister(std::uint16_t, std::uint32_t value, SimTime) override {
    value_ = value;
    return WriteResult::Accepted;
  }
  void reset() override { value_ = 0; }  // LEDs off
  // The LEDs take the top `count` data bits.
  [[nodiscard]] std::uint32_t leds() const { return count_ ? value_ >> (32 - count_) : 0; }
  [[nodiscard]] State state() const { return State{count_, leds()}; }

 private:
  unsigned count_;
  std::uint32_t value_ = 0;
};

}  // namespace lbpkit::model::hm2
