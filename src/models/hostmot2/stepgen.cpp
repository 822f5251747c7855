// SPDX-License-Identifier: MIT
#include "hostmot2/stepgen.hpp"

#include <algorithm>
#include <limits>

#include "hostmot2/dpll.hpp"

namespace lbpkit::model::hm2 {

namespace {
constexpr std::uint64_t kAccumMask = (std::uint64_t{1} << 48) - 1;
constexpr std::uint64_t kOneStep = std::uint64_t{1} << 32;  // bit 32: the accumulator's integer part
constexpr std::uint64_t kNever = std::numeric_limits<std::uint64_t>::max();
// Steady spans are worked out at most this many ticks at a time, so that
// ticks * |rate| (< 2^31 * 2^30) stays inside 64 bits.
constexpr std::uint64_t kSpanChunk = std::uint64_t{1} << 30;

// The fraction (bits 31..0) as a distance from the last step, in the
// direction of travel: a step is due when it reaches 2^32.
std::uint64_t progress(std::uint64_t accum, bool up) {
  const std::uint64_t f = accum & (kOneStep - 1);
  return up ? f : kOneStep - 1 - f;
}
// Adds (of |rate|) from `u` until the one that steps.
std::uint64_t addsToStep(std::uint64_t u, std::uint64_t speed) { return (kOneStep - u + speed - 1) / speed; }
std::uint64_t addsFor(std::uint64_t accum, std::int64_t rate, std::uint64_t adds) {
  return (accum + adds * static_cast<std::uint64_t>(rate)) & kAccumMask;
}
}  // namespace

StepGen::StepGen(std::uint16_t base, unsigned instances, std::uint32_t clockLow, std::uint8_t version)
    : Module(kKind, base, std::min(instances, kMaxInstances), version), clock_(clockLow) {
  StepGen::reset();
}

std::uint32_t StepGen::modeMask() const {
  std::uint32_t m = 0x3U;
  if (supportsSwap()) m |= kSwapStepDir;
  if (supportsIndex()) m |= 0xF0U;
  return m;
}

void StepGen::reset() {
  // Power-up: every register 0 (rate 0: no steps), outputs low, the table
  // empty. The steps already made are the machine's and stay counted.
  runTo(tick_);
  for (auto& c : ch_) {
    const std::int64_t steps = c.steps;
    c = Channel{};
    c.steps = c.tableOrigin = steps;
  }
  masterRate_ = 0;
  timerSelect_ = 0;
}

void StepGen::step(Channel& c, std::uint64_t crossing, bool up) const {
  // kubstepgenz.vhd: the carry is seen one tick later; the pulse is high for
  // pulse width + 1 ticks, then low for the idle time, and the next stepping
  // add waits until both are over (with no width the pulse never ends, as
  // in the firmware). The direction may change only after the hold time.
  c.steps += up ? 1 : -1;
  const std::uint64_t rise = crossing + 1;
  c.stepAt = rise;
  if (c.pulseWidth == 0) {
    c.stepHighTo = kNever;
    c.pulseFreeAt = rise + 1;
  } else {
    c.stepHighTo = rise + c.pulseWidth;
    c.pulseFreeAt = rise + c.pulseWidth + 2 + (c.pulseIdle > 0 ? c.pulseIdle + 1U : 0U);
  }
  c.dirFreeAt = rise + c.dirHold + 1;
}

void StepGen::run(Channel& c, std::uint64_t to) const {
  std::uint64_t t = tick_;
  while (t < to) {
    const bool up = (c.rate >> 31) == 0;
    const auto rate = static_cast<std::int64_t>(static_cast<std::int32_t>(c.rate));
    const auto speed = static_cast<std::uint64_t>(rate < 0 ? -rate : rate);
    // Adds that do not step happen every tick; the one that steps needs
    // every timer clear and the direction output matching the rate's sign.
    const std::uint64_t n = speed == 0 ? kNever : addsToStep(progress(c.accum, up), speed);
    if (c.dirOut != !up) {
      // A direction change waits for the hold time after the last step;
      // then the setup time runs before the next step.
      const std::uint64_t change = std::max(t + 1, c.dirFreeAt);
      const std::uint64_t until = std::min(change, to);
      c.accum = addsFor(c.accum, rate, std::min(until - t, n - 1));
      t = until;
      if (change > to) break;
      c.dirOut = !up;
      c.setupFreeAt = change + c.dirSetup + 1;
      continue;
    }
    if (speed == 0) break;
    const std::uint64_t crossing = std::max({t + n, c.pulseFreeAt, c.setupFreeAt});
    if (crossing > to) {
      c.accum = addsFor(c.accum, rate, std::min(to - t, n - 1));
      break;
    }
    c.accum = addsFor(c.accum, rate, n);
    t = crossing;
    step(c, crossing, up);
    runSteady(c, t, to);
  }
}

void StepGen::runSteady(Channel& c, std::uint64_t& t, std::uint64_t to) const {
  // Just after a step (t is its add), at a constant rate with the direction
  // settled: every later step is either free (each step's adds take at least
  // the pulse's time) or held (each takes at most that: steps come exactly
  // that far apart). The adds a step takes differ by at most one, so one of
  // the two always holds. Either way the accumulator's value at each step
  // is as if nothing were held, so the count is arithmetic.
  const bool up = (c.rate >> 31) == 0;
  const auto rate = static_cast<std::int64_t>(static_cast<std::int32_t>(c.rate));
  const auto speed = static_cast<std::uint64_t>(rate < 0 ? -rate : rate);
  const std::uint64_t gap = c.pulseFreeAt - t;
  const std::uint64_t fewest = addsToStep(speed - 1, speed);
  const std::uint64_t most = addsToStep(0, speed);
  while (t < to) {
    const std::uint64_t span = std::min(to - t, kSpanChunk);
    const std::uint64_t u = progress(c.accum, up);
    std::uint64_t stepsIn = 0;
    std::uint64_t lastAdds = 0;  // adds from t to the last step's
    std::uint64_t last = t;      // the tick of the last step's add
    std::uint64_t adds = span;   // adds from t to t + span
    if (fewest >= gap) {
      stepsIn = (u + span * speed) / kOneStep;
      if (stepsIn > 0) {
        lastAdds = (stepsIn * kOneStep - u + speed - 1) / speed;
        last = t + lastAdds;
      }
    } else if (most <= gap) {
      // Held: a step as soon as the last one's pulse is over, every gap ticks.
      const std::uint64_t next = c.pulseFreeAt;
      stepsIn = next <= t + span ? (t + span - next) / gap + 1 : 0;
      if (stepsIn > 0) {
        lastAdds = (stepsIn * kOneStep - u + speed - 1) / speed;
        last = next + (stepsIn - 1) * gap;
      }
      // After the last step the adds go on until the next would step.
      const std::uint64_t after = progress(addsFor(c.accum, rate, lastAdds), up);
      adds = lastAdds + std::min(t + span - last, addsToStep(after, speed) - 1);
    } else {
      return;  // cannot happen (see above); run() goes on step by step
    }
    c.accum = addsFor(c.accum, rate, adds);
    if (stepsIn > 0) {
      c.steps += up ? static_cast<std::int64_t>(stepsIn - 1) : -static_cast<std::int64_t>(stepsIn - 1);
      step(c, last, up);
    }
    t += span;
  }
}

void StepGen::runTo(std::uint64_t to) {
  if (to <= tick_) return;
  for (unsigned n = 0; n < instances_; ++n) run(ch_[n], to);
  tick_ = to;
}

void StepGen::advance(SimTime now) {
  const std::uint64_t to = clockTicks(now, clock_);
  if (to <= tick_) return;
  // With a DPLL timer selected, every accumulator is latched at the timer's
  // last rising edge: run to it, latch, then on.
  if ((timerSelect_ & kTimerEnable) != 0 && dpll_ != nullptr) {
    const auto edge = dpll_->lastRisingEdge((timerSelect_ >> 12) & 7U, now);
    if (edge && *edge > lastLatch_) {
      runTo(std::min(*edge, to));
      lastLatch_ = *edge;
      for (auto& c : ch_) c.latched = static_cast<std::uint32_t>(c.accum >> 16);
    }
  }
  runTo(to);
}

std::uint32_t StepGen::readRegister(std::uint16_t address, SimTime now) {
  advance(now);
  const unsigned reg = block(address);
  const Channel& c = ch_[(address & 0xFFU) / 4];
  // The firmware drives only the accumulator (and, in 0xC2, the mode) back
  // onto the bus (kubstepgenz.vhd: the other readbacks are left out for
  // size); lbpkit reads back what was written, which no driver relies on.
  switch (reg) {
    case kRate: return c.rate;
    case kAccumulator:
      if ((timerSelect_ & kTimerEnable) != 0 && dpll_ != nullptr) return c.latched;
      return static_cast<std::uint32_t>(c.accum >> 16);
    case kMode: return c.mode;
    case kDirSetup: return c.dirSetup;
    case kDirHold: return c.dirHold;
    case kPulseWidth: return c.pulseWidth;
    case kPulseIdle: return c.pulseIdle;
    case kTableData: return c.table[0];
    case kTableLength: return c.tableLast;
    case kMasterRate: return masterRate_;
    case kTimerSelect: return timerSelect_;
    default: return 0;
  }
}

WriteResult StepGen::writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) {
  advance(now);
  const unsigned reg = block(address);
  Channel& c = ch_[(address & 0xFFU) / 4];
  constexpr std::uint32_t kTimer = 0x3FFF;  // 14-bit timers (timersize)
  switch (reg) {
    case kRate: c.rate = value; break;
    case kAccumulator:
      // Bits 47..16; the low 16 stay. Loading does not step.
      c.accum = ((std::uint64_t{value} << 16) | (c.accum & 0xFFFFU)) & kAccumMask;
      break;
    case kMode: c.mode = value & modeMask(); break;
    case kDirSetup: c.dirSetup = static_cast<std::uint16_t>(value & kTimer); break;
    case kDirHold: c.dirHold = static_cast<std::uint16_t>(value & kTimer); break;
    case kPulseWidth: c.pulseWidth = static_cast<std::uint16_t>(value & kTimer); break;
    case kPulseIdle: c.pulseIdle = static_cast<std::uint16_t>(value & kTimer); break;
    case kTableData:
      // A shift register (SRL16E): the new pattern at index 0.
      std::copy_backward(c.table.begin(), c.table.end() - 1, c.table.end());
      c.table[0] = value;
      break;
    case kTableLength:
      c.tableLast = static_cast<std::uint8_t>(value & 0xFU);
      c.tableOrigin = c.steps;
      break;
    case kMasterRate: masterRate_ = value; break;
    case kTimerSelect: timerSelect_ = value & 0xF000U; break;
    default: return WriteResult::Unmapped;
  }
  return WriteResult::Accepted;
}

StepGen::Pins StepGen::pinsOf(const Channel& c) const {
  const bool pulse = c.stepAt != 0 && tick_ >= c.stepAt && tick_ <= c.stepHighTo;
  std::uint32_t out = 0;
  switch (c.mode & 3U) {
    case 0: out = (pulse ? 1U : 0U) | (c.dirOut ? 2U : 0U); break;
    case 1: out = (pulse && !c.dirOut ? 1U : 0U) | (pulse && c.dirOut ? 2U : 0U); break;
    case 2: {
      // Quadrature from accumulator bits 31..30: 00, 01, 11, 10.
      const auto q = static_cast<unsigned>((c.accum >> 30) & 3U);
      static constexpr std::array<std::uint32_t, 4> kGray{0U, 1U, 3U, 2U};
      out = kGray[q];
      break;
    }
    default: {
      const std::int64_t len = c.tableLast + 1;
      const std::int64_t at = ((c.steps - c.tableOrigin) % len + len) % len;
      out = c.table[static_cast<std::size_t>(at)];
      break;
    }
  }
  if ((c.mode & kSwapStepDir) != 0) out = (out & ~3U) | ((out & 1U) << 1) | ((out >> 1) & 1U);
  return Pins{(out & 1U) != 0, (out & 2U) != 0, out};
}

std::int64_t StepGen::steps(unsigned n, SimTime now) {
  advance(now);
  return ch_.at(n).steps;
}

StepGen::Pins StepGen::pins(unsigned n, SimTime now) {
  advance(now);
  return pinsOf(ch_.at(n));
}

double StepGen::stepRate(unsigned n) const {
  return static_cast<double>(static_cast<std::int32_t>(ch_.at(n).rate)) * clock_ / 4294967296.0;
}

StepGen::State StepGen::state(SimTime now) {
  advance(now);
  State s;
  s.instances = instances_;
  s.masterRate = masterRate_;
  s.timerSelect = timerSelect_;
  for (unsigned n = 0; n < instances_; ++n) {
    const Channel& c = ch_[n];
    s.channel[n] = {c.rate, static_cast<std::uint32_t>(c.accum >> 16), c.mode, c.steps, pinsOf(c)};
  }
  return s;
}

}  // namespace lbpkit::model::hm2
