// HostMot2 watchdog (HostMot2 regmap; watchdog.vhd; docs/protocol-facts.md#hostmot2-watchdog).
//   0x0C00 timer   32 bits, counts down at ClockLow while bit 31 is 0; a write
//                  loads the timer and its reload value (0x80000000: disarmed
//                  when it is not running; written while it runs, bit 31
//                  rising bites, as watchdog.vhd's edge detector does)
//   0x0D00 status  bit 0: bitten (read/write)
//   0x0E00 reset   a write whose top byte is 0x5A reloads the timer with the
//                  value last written to 0x0C00 ("pet"; after a bite too)
// When the timer's bit 31 rises (it passes zero) the watchdog bites: the status bit is set and
// the card's GPIO is reset (the owner is told through onBite).
#pragma once

#include <cstdint>
#include <functional>

#include "hostmot2/module.hpp"

namespace hm2 {

class Watchdog final : public Module {
 public:
  static constexpr std::uint16_t kTimer = 0x0C00;
  static constexpr std::uint16_t kStatus = 0x0D00;
  static constexpr std::uint16_t kReset = 0x0E00;
  static constexpr std::uint32_t kDisarmed = 0x80000000U;

  // What an observer sees (the status bit and the timer as a read at `now`
  // would return them), without the read's side effect of advancing.
  struct State {
    bool bitten = false;
    std::uint32_t timer = kDisarmed;
  };

  Watchdog(std::uint32_t clockLow, std::function<void()> onBite);

  [[nodiscard]] std::string_view name() const override { return "WatchDog"; }
  [[nodiscard]] ModuleDescriptor descriptor() const override {
    return ModuleDescriptor{tag::kWatchdog, 0, kClockLow, 1, kTimer, 3, 0, 0};
  }
  [[nodiscard]] bool decodes(std::uint16_t a) const override { return a >= kTimer && a < kReset + 4; }
  std::uint32_t read(std::uint16_t address, SimTime now) override;
  WriteResult write(std::uint16_t address, std::uint32_t value, SimTime now) override;
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

}  // namespace hm2
