// SPDX-License-Identifier: MIT
#include "hostmot2/dpll.hpp"

#include <algorithm>

namespace lbpkit::model::hm2 {

namespace {
// A 24-bit two's complement field as a signed number.
std::int32_t signed24(std::uint32_t v) {
  v &= 0xFFFFFFU;
  return (v & 0x800000U) ? static_cast<std::int32_t>(v) - 0x1000000 : static_cast<std::int32_t>(v);
}
}  // namespace

Dpll::Dpll(std::uint16_t base, unsigned instances, std::uint32_t clockLow, std::uint8_t version)
    // There is only ever one (LinuxCNC hostmot2(9), num_dplls).
    : Module(kKind, base, 1, version), clock_(clockLow) {
  (void)instances;
  Dpll::reset();
}

void Dpll::reset() {
  // Power-up: every register 0 (the FPGA's flip-flops start cleared), so
  // the loop does not run until a base rate is written. Simulated time goes on.
  nextAddTick_ = tick_ + 1;
  lastAddTick_ = 0;
  addsToFilter_ = 1;
  accum_ = 0;
  baseRate_ = 0;
  phaseError_ = 0;
  bounded_ = filtered_ = 0;
  prescale_ = 0;
  phaseLimit_ = 0;
  filterPrescale_ = 0;
  timer_.fill(0);
}

std::int32_t Dpll::correction() const {
  // hmtimers.vhd: the filtered error plus a sixteenth of the limited one, 24 bits.
  return signed24(static_cast<std::uint32_t>(filtered_ + (bounded_ >> 4)));
}

void Dpll::takePhaseError() {
  // A sync access latches the accumulator's top 32 bits as the phase error;
  // its top 24 bits, limited to +-limit, drive the loop.
  phaseError_ = phaseTop();
  const std::int32_t e = static_cast<std::int32_t>(phaseError_) >> 8;
  bounded_ = std::clamp(e, -phaseLimit_, phaseLimit_);
}

void Dpll::runAdds(std::uint64_t adds) {
  // Between filter updates the correction is constant: the accumulator moves
  // by adds * (base rate - correction), modulo 2^42 (unsigned arithmetic
  // wraps modulo 2^64, a multiple of it). The filter moves a 256th of the
  // way to the limited error every filterAdds() adds, and stops moving once
  // the step rounds to nothing: from then on the rest is one span.
  while (adds > 0) {
    const auto step = static_cast<std::uint64_t>(std::int64_t{baseRate_} - correction());
    const std::uint64_t m = std::min<std::uint64_t>(adds, addsToFilter_);
    accum_ = (accum_ + m * step) & kMask;
    adds -= m;
    addsToFilter_ -= static_cast<unsigned>(m);
    if (addsToFilter_ != 0) continue;
    addsToFilter_ = filterAdds();
    const std::int32_t next = signed24(static_cast<std::uint32_t>(filtered_ + (bounded_ >> 8) - (filtered_ >> 8)));
    if (next != filtered_) {
      filtered_ = next;
      continue;
    }
    const auto rest = static_cast<std::uint64_t>(std::int64_t{baseRate_} - correction());
    accum_ = (accum_ + adds * rest) & kMask;
    const std::uint64_t fa = filterAdds();
    addsToFilter_ = static_cast<unsigned>(fa - adds % fa);
    if (addsToFilter_ == 0) addsToFilter_ = static_cast<unsigned>(fa);
    adds = 0;
  }
}

void Dpll::advance(SimTime now) {
  const std::uint64_t t = clockTicks(now, clock_);
  if (t <= tick_) return;
  tick_ = t;
  if (nextAddTick_ > t) return;
  // The accumulator adds every prescale ticks (hmtimers.vhd's prescale counter).
  const std::uint64_t p = prescaleTicks();
  const std::uint64_t adds = (t - nextAddTick_) / p + 1;
  lastAddTick_ = nextAddTick_ + (adds - 1) * p;
  nextAddTick_ += adds * p;
  runAdds(adds);
}

std::optional<std::uint64_t> Dpll::lastRisingEdge(unsigned source, SimTime now) {
  advance(now);
  const std::int64_t step = std::int64_t{baseRate_} - correction();
  if (source >= kRateSources || step <= 0 || lastAddTick_ == 0) return std::nullopt;
  // The reference rises as the accumulator wraps through 0 (refout is its
  // inverted MSB), timer k as its top 16 bits pass -offset (the timer output
  // is bit 15 of their sum, inverted).
  const std::uint64_t target =
      source == 0 ? 0 : std::uint64_t{static_cast<std::uint16_t>(0x10000U - timer_[source - 1])} << (kAccumulatorBits - 16);
  const std::uint64_t since = (accum_ - target) & kMask;  // how far past it the accumulator is
  const std::uint64_t addsAgo = since / static_cast<std::uint64_t>(step);
  const std::uint64_t back = addsAgo * prescaleTicks();
  if (back >= lastAddTick_) return std::nullopt;
  return lastAddTick_ - back;
}

std::uint32_t Dpll::readRegister(std::uint16_t address, SimTime now) {
  advance(now);
  switch (block(address)) {
    case kBaseRate: return baseRate_;
    case kPhase: return phaseTop();
    case kControl0:
      return (std::uint32_t{prescale_} << 24) | (static_cast<std::uint32_t>(correction()) & 0xFFFFFFU);
    case kControl1: return (std::uint32_t{filterPrescale_} << 16) | kAccumulatorBits;
    case kTimers12: return timer_[0] | (std::uint32_t{timer_[1]} << 16);
    case kTimers34: return timer_[2] | (std::uint32_t{timer_[3]} << 16);
    case kSync: takePhaseError(); return phaseTop();
    default: return 0;
  }
}

WriteResult Dpll::writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) {
  advance(now);
  switch (block(address)) {
    case kBaseRate: baseRate_ = value; break;
    case kPhase: {
      // The top 32 of the 42 bits; the 10 below stay.
      constexpr unsigned kLow = kAccumulatorBits - 32;
      accum_ = ((std::uint64_t{value} << kLow) | (accum_ & ((1U << kLow) - 1))) & kMask;
      break;
    }
    case kControl0:
      phaseLimit_ = signed24(value);
      if (phaseLimit_ < 0) phaseLimit_ = -phaseLimit_;
      prescale_ = static_cast<std::uint8_t>(value >> 24);
      filtered_ = 0;
      phaseError_ = 0;
      bounded_ = 0;
      break;
    case kControl1: filterPrescale_ = static_cast<std::uint16_t>(value >> 16); break;
    case kTimers12:
      timer_[0] = static_cast<std::uint16_t>(value);
      timer_[1] = static_cast<std::uint16_t>(value >> 16);
      break;
    case kTimers34:
      timer_[2] = static_cast<std::uint16_t>(value);
      timer_[3] = static_cast<std::uint16_t>(value >> 16);
      break;
    case kSync: takePhaseError(); break;
    default: return WriteResult::Unmapped;
  }
  return WriteResult::Accepted;
}

Dpll::State Dpll::state() const {
  State s;
  s.baseRate = baseRate_;
  s.phase = phaseTop();
  s.phaseError = phaseError_;
  s.prescale = prescale_;
  s.phaseLimit = static_cast<std::uint32_t>(phaseLimit_);
  s.filterPrescale = filterPrescale_;
  s.correction = correction();
  s.timer = timer_;
  return s;
}

}  // namespace lbpkit::model::hm2
