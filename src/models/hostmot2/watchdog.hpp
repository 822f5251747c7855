// SPDX-License-Identifier: MIT
// HostMot2 watchdog (HostMot2 regmap; watchdog.vhd; docs/protocol-facts.md#hostmot2-watchdog).
// Registers (their addresses: lbpkit/wire/hostmot2_modules.hpp):
//   timer   32 bits, counts down at ClockLow while bit 31 is 0; a write
//           loads the timer and its reload value (bit 31 set: disarmed
//           when it is not running; written while it runs, bit 31
//           rising bites, as watchdog.vhd's edge detector does)
//   status  bit 0: bitten (read/write)
//   reset   a write whose top byte is 0x5A reloads the timer with the
//           value last written to the timer ("pet"; after a bite too)
// When the timer's bit 31 rises (it passes zero) the watchdog bites: the status bit is set and
// the card's GPIO is reset (the owner is told through onBite).
#pragma once

#include <cstdint>
#include <functional>

#include "hostmot2/module.hpp"

namespace lbpkit::model::hm2 {

class Watchdog final : public Module {
 public:
  static constexpr const ModuleKind& kKind = map::kWatchdog;
  static constexpr std::uint16_t kTimer = kKind.address(map::watchdog::kTimer);
  static constexpr std::uint16_t kStatus = kKind.address(map::watchdog::kStatus);
  static constexpr std::uint16_t kReset = kKind.address(map::watchdog::kReset);
  static constexpr std::uint32_t kDisarmed = map::watchdog::kDisarmed;

  // What an observer sees (the status bit and the timer as a read at `now`
  // would return them), without the read's side effect of advancing.
  struct State {
    bool bitten = false;
    std::uint32_t timer = kDisarmed;
  };

  Watchdog(std::uint32_t clockLow, std::function<void()> onBite);

  // The timer and status registers answer at every word of their blocks
  // (watchdog.vhd decodes them by the address's top byte), the reset
  // register at its first.
  [[nodiscard]] bool decodes(std::uint16_t a) const override { return a >= kTimer && a < kReset + 4; }
  std::uint32_t readRegister(std::uint16_t address, SimTime now) override;
  WriteResult writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) override;
  // One comparison until the timer passes zero (the card calls it at every access).
  void advance(SimTime now) override {
    if (running_ && now >= biteAt_) bite();
  }
  void reset() override;  // disarmed, not bitten

  [[nodiscard]] bool bitten() const { return bitten_; }
  [[nodiscard]] std::uint32_t timer(SimTime now) const;
  [[nodiscard]] State state(SimTime now) const { return State{bitten_, timer(now)}; }

 private:
  void start(SimTime now);
  void load(std::uint32_t value, SimTime now);  // the timer register takes `value`
  // The MSB edge: status bit set, GPIO released; the timer stops at `timer`
  // (0xFFFFFFFF when it counted past zero, else the value written).
  void bite(std::uint32_t timer = 0xFFFFFFFFU);
  std::uint32_t clockLow_;
  std::function<void()> onBite_;
  // The timer's value when it was loaded (running) or where it stands (stopped).
  std::uint32_t reload_ = kDisarmed;
  // watchdog.vhd's wdtime: the value last written to the timer register,
  // which a pet (0x5A in the top byte of a cookie write) loads the timer with.
  std::uint32_t time_ = kDisarmed;
  SimTime loadedAt_{};
  // While running: the first time the timer has passed zero (timer() reads
  // 0xFFFFFFFF from then on), so advance() is one comparison until then.
  SimTime biteAt_{};
  bool running_ = false;  // counting down (bit 31 clear)
  bool bitten_ = false;
};

}  // namespace lbpkit::model::hm2
