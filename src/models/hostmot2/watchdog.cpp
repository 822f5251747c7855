#include "hostmot2/watchdog.hpp"

namespace hm2 {

Watchdog::Watchdog(std::uint32_t clockLow, std::function<void()> onBite)
    : clockLow_(clockLow), onBite_(std::move(onBite)) {}

std::uint32_t Watchdog::timer(SimTime now) const {
  if (!running_) return reload_;
  const auto ticks = clockTicks(now - loadedAt_, clockLow_);
  if (ticks > reload_) return 0xFFFFFFFFU;  // passed zero: bit 31 set, counting stopped
  return static_cast<std::uint32_t>(reload_ - ticks);
}

void Watchdog::advance(SimTime now) {
  if (!running_ || timer(now) != 0xFFFFFFFFU) return;
  running_ = false;
  reload_ = 0xFFFFFFFFU;
  bitten_ = true;
  if (onBite_) onBite_();
}

std::uint32_t Watchdog::read(std::uint16_t address, SimTime now) {
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
  reload_ = kDisarmed;
  loadedAt_ = SimTime{};
  running_ = false;
  bitten_ = false;
}

WriteResult Watchdog::write(std::uint16_t address, std::uint32_t value, SimTime now) {
  advance(now);
  switch (address & 0xFF00U) {
    case kTimer:
      reload_ = value;
      loadedAt_ = now;
      running_ = (value & kDisarmed) == 0;
      break;
    case kStatus:
      bitten_ = (value & 1U) != 0;
      break;
    case kReset:
      if ((value >> 24) == 0x5A && (reload_ & kDisarmed) == 0) {
        loadedAt_ = now;
        running_ = true;
      }
      break;
    default:
      return WriteResult::Unmapped;
  }
  return WriteResult::Accepted;
}

}  // namespace hm2
