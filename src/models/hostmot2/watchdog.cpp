// SPDX-License-Identifier: MIT
#include "hostmot2/watchdog.hpp"

namespace lbpkit::model::hm2 {

Watchdog::Watchdog(std::uint32_t clockLow, std::function<void()> onBite)
    : Module(kKind, kKind.base, 1, kKind.version),
      clockLow_(clockLow), onBite_(std::move(onBite)) {}

std::uint32_t Watchdog::timer(SimTime now) const {
  if (!running_) return reload_;
  const auto ticks = clockTicks(now - loadedAt_, clockLow_);
  if (ticks > reload_) return 0xFFFFFFFFU;  // passed zero: bit 31 set, counting stopped
  return static_cast<std::uint32_t>(reload_ - ticks);
}

void Watchdog::start(SimTime now) {
  loadedAt_ = now;
  running_ = true;
  // timer() passes zero when clockTicks(elapsed) > reload_, i.e. (ticks being
  // floor(elapsed * clockLow_ / 1e9)) once elapsed reaches
  // ceil((reload_ + 1) * 1e9 / clockLow_) nanoseconds. reload_ < 2^31 while
  // running, so this fits 64 bits.
  if (clockLow_ == 0) {  // a clock that never ticks never bites
    biteAt_ = SimTime::max();
    return;
  }
  const std::uint64_t ticks = std::uint64_t{reload_} + 1;
  const std::uint64_t ns = (ticks * 1'000'000'000U + clockLow_ - 1) / clockLow_;
  biteAt_ = now + SimTime{static_cast<std::int64_t>(ns)};
}

void Watchdog::bite(std::uint32_t timer) {
  running_ = false;
  reload_ = timer;
  bitten_ = true;
  if (onBite_) onBite_();
}

std::uint32_t Watchdog::readRegister(std::uint16_t address, SimTime now) {
  advance(now);
  switch (address & 0xFF00U) {
    case kTimer: return timer(now);
    case kStatus: return bitten_ ? 1U : 0U;
    default: return 0;
  }
}

void Watchdog::reset() {
  // Power-up (HostMot2 regmap, watchdog; docs/protocol-facts.md#hostmot2-watchdog):
  // disarmed (bit 31 set) and not bitten.
  reload_ = time_ = kDisarmed;
  loadedAt_ = SimTime{};
  running_ = false;
  bitten_ = false;
}

void Watchdog::load(std::uint32_t value, SimTime now) {
  // watchdog.vhd bites on the timer's MSB going from 0 to 1, whatever set
  // it: counting past zero, or loading a value with bit 31 set while it
  // runs (so 0x80000000 written to a running watchdog bites; it disarms only
  // one that is not running, as LinuxCNC uses it before its first pet).
  const bool wasRunning = running_;
  reload_ = value;
  loadedAt_ = now;
  running_ = false;
  if ((value & kDisarmed) == 0)
    start(now);
  else if (wasRunning)
    bite(value);
}

WriteResult Watchdog::writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) {
  advance(now);
  switch (address & 0xFF00U) {
    case kTimer:
      time_ = value;
      load(value, now);
      break;
    case kStatus:
      bitten_ = (value & 1U) != 0;
      break;
    case kReset:
      // A pet loads the timer from the value last written (wdtime), also
      // after a bite: the timer runs again (the status bit stays).
      if ((value >> 24) == map::watchdog::kPetCookie) load(time_, now);
      break;
    default:
      return WriteResult::Unmapped;
  }
  return WriteResult::Accepted;
}

}  // namespace lbpkit::model::hm2
