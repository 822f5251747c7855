// HostMot2 LED module (HostMot2 regmap: LED; docs/protocol-facts.md#module-tags):
//   0x0200 the card's LEDs, one write-only register; the LEDs take its top
//          `count` bits (CR1..CR4 on a 7I92)
#pragma once

#include <cstdint>

#include "hostmot2/module.hpp"

namespace hm2 {

class Led final : public Module {
 public:
  static constexpr std::uint16_t kLeds = 0x0200;
  struct State {
    unsigned count = 0;
    std::uint32_t leds = 0;  // as leds() gives them
  };
  explicit Led(unsigned count) : count_(count) {}
  [[nodiscard]] std::string_view name() const override { return "LED"; }
  [[nodiscard]] ModuleDescriptor descriptor() const override {
    return ModuleDescriptor{tag::kLed, 0, kClockLow, 1, kLeds, 1, 0, 0};
  }
  [[nodiscard]] bool decodes(std::uint16_t a) const override { return a == kLeds; }
  std::uint32_t read(std::uint16_t, SimTime) override { return 0; }  // write only
  WriteResult write(std::uint16_t, std::uint32_t value, SimTime) override {
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

}  // namespace hm2
