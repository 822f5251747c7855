// SPDX-License-Identifier: MIT
#include "hostmot2/muxed_encoder.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lbpkit::model::hm2 {

namespace {
namespace reg = lbpkit::wire::qcount::reg;

// Positions inside a quadrature state: the state index is floor(position).
// static_cast<std::int64_t>(std::floor(position)), without the library call:
// truncation, one less below zero when that truncated upwards.
std::int64_t stateOf(double position) {
  const auto t = static_cast<std::int64_t>(position);
  return static_cast<double>(t) > position ? t - 1 : t;
}
// More samples than this in one step are not simulated one by one: at such
// rates the filter passes nothing and every count is lost.
constexpr std::int64_t kMaxSimulatedSamples = 2'000'000;

// The largest v > 0 whose 1 / v, as a double, is still at least `seconds`
// (> 0). A correctly rounded 1 / v falls as v grows, so for every v > 0
// (and NaN and infinity alike) `1.0 / v >= seconds` is `v <= this`: run()
// makes the decision the division made, without dividing.
double maxFilteredVelocity(double seconds) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  double v = 1.0 / seconds;
  while (v > 0 && !(1.0 / v >= seconds)) v = std::nextafter(v, 0.0);
  while (1.0 / std::nextafter(v, kInf) >= seconds) v = std::nextafter(v, kInf);
  return v;
}
}  // namespace

MuxedEncoder::MuxedEncoder(unsigned counters, std::uint32_t clockLow) : MuxedEncoder(counters, clockLow, Variant{}) {}

MuxedEncoder::MuxedEncoder(unsigned counters, std::uint32_t clockLow, const Variant& variant)
    : Module(*variant.kind, variant.base, std::min(counters, kMaxCounters), variant.version),
      variant_(variant),
      counters_(instances_),
      clockLow_(clockLow) {
  MuxedEncoder::reset();
}

void MuxedEncoder::reset() {
  settle();
  // Power-up mux rate: the firmware's round(ClockLow / 8 MHz) - 2
  // (qcounteratesk.vhd, VHDL round: halves away from zero), 11 at 100 MHz:
  // a tick every 13 ClockLow, 7.69 MHz. LinuxCNC writes its own at load:
  // ClockLow / muxed-sample-frequency (8 MHz) - 2, truncated, 10 at 100 MHz
  // (8.33 MHz; encoder.c).
  // (The plain QCount's qcounterate.vhd: round(ClockLow / 16 MHz) - 2.)
  const std::uint32_t hz = variant_.powerUpTickHz;
  rateDivisor_ = std::max((clockLow_ + hz / 2) / hz, 2U) - 2;
  setSamplePeriod();
  tsDivisor_ = 0;
  timerSelect_ = 0;
  latched_ = false;
  lastLatch_ = 0;
  // Counts, CCRs and latches cleared; the filters start from the inputs as
  // they are now (the encoders do not move because the card restarts).
  for (unsigned n = 0; n < kMaxCounters; ++n) {
    Counter& c = state_[n];
    c = Counter{};
    c.filtered = c.candidate = stateOf(signals_[n].position);
  }
}

void MuxedEncoder::setSamplePeriod() {
  // Each muxed counter sees its inputs every second mux tick (a plain one every tick).
  samplePeriod_ = SimTime{static_cast<std::int64_t>(variant_.ticksPerSample * (rateDivisor_ + 2.0) * 1e9 / clockLow_)};
  samplePeriodSeconds_ = std::chrono::duration<double>(samplePeriod_).count();
  maxFilteredVelocity_[0] = maxFilteredVelocity(samplePeriodSeconds_ * variant_.filterSamples[0]);
  maxFilteredVelocity_[1] = maxFilteredVelocity(samplePeriodSeconds_ * variant_.filterSamples[1]);
}

std::uint16_t MuxedEncoder::timestampAt(SimTime t) const {
  const auto ticks = clockTicks(t, clockLow_) / (tsDivisor_ + 2);
  return static_cast<std::uint16_t>(ticks);
}

void MuxedEncoder::setIndexPeriod(unsigned n, std::uint32_t countsPerRev, std::int64_t indexAt) {
  settle(n);
  signals_.at(n).countsPerRev = countsPerRev;
  signals_.at(n).indexAt = indexAt;
}

MuxedEncoder::State MuxedEncoder::state() const {
  settle();
  State s;
  s.counters = counters_;
  for (unsigned n = 0; n < counters_; ++n) s.counter[n] = {count(n), control(n), signals_[n]};
  return s;
}

void MuxedEncoder::settle() const {
  for (unsigned n = 0; n < kMaxCounters; ++n) settle(n);
}

void MuxedEncoder::index(Counter& c, std::int64_t countAtIndex) {
  if (c.ccr & kLatchOnIndex) c.latched = static_cast<std::uint16_t>(countAtIndex);
  if (c.ccr & kClearOnIndex) c.count = 0;
  // "Just once": index enable resets itself after the first index (LinuxCNC
  // watches latch-on-index read back 0 to see that the index came).
  if (c.ccr & kJustOnce) c.ccr &= ~(kClearOnIndex | kLatchOnIndex | kJustOnce);
}

void MuxedEncoder::run(unsigned n, SimTime from, SimTime to) const {
  // The common case stays short (a plant span moves each counter a few
  // states): index pulses while clear or latch on index is armed, and rates
  // too fast for the filter, are out of line.
  EncoderSignal& s = signals_[n];
  Counter& c = state_[n];
  // Most runs are one plant span long (the machine sets every velocity each
  // span): the span's seconds are worked out again only when it changes,
  // as a division costs more than the rest of the common case.
  if (to - from != lastSpan_) {
    lastSpan_ = to - from;
    lastSpanSeconds_ = std::chrono::duration<double>(lastSpan_).count();
  }
  const double dt = lastSpanSeconds_;
  const double p0 = s.position;
  const double p1 = p0 + s.velocity * dt;
  s.position = p1;
  if (s.velocity == 0.0) return;
  // A quadrature state lasts 1 / |velocity|: shorter than the filter's
  // time (samplePeriodSeconds_ * filterSamples(c)), and it is sampled.
  if (std::abs(s.velocity) > maxFilteredVelocity_[(c.ccr & kFilter) ? 1 : 0]) return runSampled(s, c, from, to, p0);
  // Slow enough for the filter: every state change is seen and counted.
  const std::int64_t a = stateOf(p0);
  const std::int64_t b = stateOf(p1);
  if (a == b) return;
  c.filtered = c.candidate = b;
  c.stable = filterSamples(c);  // (an index does not change the filter bit)
  // The timestamp of the last count: when the position entered state b.
  c.stamp = Counter::Stamp::Edge;
  c.from = from;
  c.edgeCounts = b > a ? static_cast<double>(b) : static_cast<double>(b + 1);
  c.p0 = p0;
  c.velocity = s.velocity;
  // Last, so that the common case makes no call that needs its values kept.
  if (s.countsPerRev > 0 && (c.ccr & (kClearOnIndex | kLatchOnIndex))) return countAcrossIndexes(s, c, a, b);
  c.count += static_cast<std::int32_t>(b - a);
}

void MuxedEncoder::countAcrossIndexes(const EncoderSignal& s, Counter& c, std::int64_t a, std::int64_t b) {
  // Index pulses are one count wide, every countsPerRev from indexAt. Only
  // the first and the last one crossed while clear or latch on index is
  // armed matter: the first may disarm it ("just once"), and between them
  // every index does the same thing. Computed, not walked: with an index
  // every count at MHz rates, one step can cross billions of them.
  const std::int64_t step = b > a ? 1 : -1;
  std::int64_t at = a;
  const auto cpr = static_cast<std::int64_t>(s.countsPerRev);
  auto floorDiv = [](std::int64_t x, std::int64_t m) { return x >= 0 ? x / m : -((-x + m - 1) / m); };
  const std::int64_t ia = s.indexAt;
  const std::int64_t first =
      step > 0 ? (floorDiv(at - ia, cpr) + 1) * cpr + ia : floorDiv(at - 1 - ia, cpr) * cpr + ia;
  if ((step > 0 && first <= b) || (step < 0 && first >= b)) {
    c.count += static_cast<std::int32_t>(first - at);
    at = first;
    index(c, c.count);
    const std::int64_t more = (step > 0 ? b - first : first - b) / cpr;  // indexes after the first
    if (more > 0 && (c.ccr & (kClearOnIndex | kLatchOnIndex))) {
      const std::int64_t last = first + step * more * cpr;
      // Counts wrap as the 32-bit counter does.
      if (c.ccr & kClearOnIndex)
        c.count = static_cast<std::int32_t>(step * cpr);  // one revolution since the index before
      else
        c.count = static_cast<std::int32_t>(static_cast<std::int64_t>(c.count) + (last - first));
      at = last;
      index(c, c.count);
    }
  }
  c.count += static_cast<std::int32_t>(b - at);
}

void MuxedEncoder::runSampled(const EncoderSignal& s, Counter& c, SimTime from, SimTime to, double p0) const {
  // Too fast for the filter: sample by sample, as the hardware does. The
  // samples fall on the free-running mux clock (multiples of the sample
  // period), not relative to `from`: what is counted does not depend on how
  // the time was split into runs.
  const SimTime sample = samplePeriod();
  const std::int64_t firstSample = from / sample + 1;
  const std::int64_t lastSample = to / sample;
  if (lastSample - firstSample >= kMaxSimulatedSamples) {
    c.filtered = c.candidate = stateOf(s.position);  // nothing counted
    return;
  }
  for (std::int64_t k = firstSample; k <= lastSample; ++k) {
    const double pos = p0 + s.velocity * std::chrono::duration<double>(sample * k - from).count();
    const std::int64_t raw = stateOf(pos);
    if ((raw & 3) == (c.candidate & 3)) {
      ++c.stable;
    } else {
      c.candidate = raw;
      c.stable = 1;
    }
    if (c.stable < filterSamples(c) || (c.candidate & 3) == (c.filtered & 3)) continue;
    const auto diff = (c.candidate - c.filtered) & 3;
    if (diff == 1) {
      ++c.count;
      c.stamp = Counter::Stamp::Sample;
      c.at = sample * k;
    } else if (diff == 3) {
      --c.count;
      c.stamp = Counter::Stamp::Sample;
      c.at = sample * k;
    } else {
      c.ccr |= kQuadError;  // A and B changed together: the count is lost
    }
    c.filtered = (c.filtered & ~std::int64_t{3}) | (c.candidate & 3);
  }
}

void MuxedEncoder::stampCount(Counter& c) const {
  switch (c.stamp) {
    case Counter::Stamp::Done: return;
    case Counter::Stamp::Edge: {
      const double tEdge = std::chrono::duration<double>(c.from).count() + (c.edgeCounts - c.p0) / c.velocity;
      c.countTimestamp = timestampAt(SimTime{static_cast<std::int64_t>(tEdge * 1e9)});
      break;
    }
    case Counter::Stamp::Sample: c.countTimestamp = timestampAt(c.at); break;
  }
  c.stamp = Counter::Stamp::Done;
}

std::uint32_t MuxedEncoder::readRegister(std::uint16_t address, SimTime now) {
  advance(now);
  const unsigned n = (address & 0xFFU) / 4;
  settle(n);  // a counter's registers show only it (the others wait until looked at)
  switch (block(address)) {
    case reg::kCount:
      if (n >= counters_) return 0;
      return latching() ? latchedCount_[n] : countRegister(n);
    case reg::kControl: {
      if (n >= counters_) return 0;
      const auto& c = state_[n];
      const auto st = c.filtered & 3;  // Gray code: 0 = 00, 1 = A, 2 = AB, 3 = B
      const bool a = st == 1 || st == 2;
      const bool b = st == 2 || st == 3;
      const auto& s = signals_[n];
      const bool z = s.countsPerRev > 0 &&
                     ((stateOf(s.position) - s.indexAt) % static_cast<std::int64_t>(s.countsPerRev)) == 0;
      return (static_cast<std::uint32_t>(c.latched) << 16) | (c.ccr & 0xFFF8U) | (z ? 4U : 0U) | (b ? 2U : 0U) |
             (a ? 1U : 0U);
    }
    case reg::kTimestampDiv: return tsDivisor_;
    case reg::kTimestamp: return latching() ? latchedTimestamp_ : timestampAt(now);
    case reg::kRate: return rateDivisor_;
    case reg::kTimerSelect: return dpll_ != nullptr ? timerSelect_ : 0;
    default: return 0;
  }
}

std::uint32_t MuxedEncoder::countRegister(unsigned n) const {
  settle(n);
  stampCount(state_[n]);
  return static_cast<std::uint16_t>(state_[n].count) | (static_cast<std::uint32_t>(state_[n].countTimestamp) << 16);
}

void MuxedEncoder::latchAtTimer(SimTime now) {
  const auto edge = dpll_->lastRisingEdge((timerSelect_ >> 12) & 7U, now);
  if (!edge || (latched_ && *edge <= lastLatch_)) return;
  // The edge's moment (ClockLow ticks; the DPLL runs on ClockLow too), never
  // before what the counters have already been brought to.
  const auto tick = *edge;
  const SimTime at{static_cast<SimTime::rep>(tick / clockLow_ * 1'000'000'000ULL +
                                             tick % clockLow_ * 1'000'000'000ULL / clockLow_)};
  if (at > pending_) pending_ = at;
  for (unsigned n = 0; n < counters_; ++n) latchedCount_[n] = countRegister(n);
  latchedTimestamp_ = timestampAt(pending_);
  lastLatch_ = tick;
  latched_ = true;
}

WriteResult MuxedEncoder::writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) {
  advance(now);
  const unsigned n = (address & 0xFFU) / 4;
  // A new mux rate or timestamp divisor changes every counter from now on:
  // each is settled under the old one first.
  if (block(address) == reg::kRate || block(address) == reg::kTimestampDiv)
    settle();
  else
    settle(n);
  switch (block(address)) {
    case reg::kCount:
      if (n >= counters_) return WriteResult::Unmapped;
      state_[n].count = 0;  // any write clears the count
      return WriteResult::Accepted;
    case reg::kControl:
      if (n >= counters_) return WriteResult::Unmapped;
      state_[n].ccr = value & 0xFFF8U;
      return WriteResult::Accepted;
    case reg::kTimestampDiv:
      for (auto& c : state_) stampCount(c);  // counts made so far are stamped under the old divisor
      tsDivisor_ = value & 0xFFFFU;
      return WriteResult::Accepted;
    case reg::kRate:
      rateDivisor_ = value & 0xFFFU;
      setSamplePeriod();
      return WriteResult::Accepted;
    case reg::kTimerSelect:
      if (dpll_ == nullptr) return WriteResult::Unmapped;
      // A new selection latches from its source's next edge on.
      if ((value & 0xF000U) != timerSelect_) latched_ = false;
      timerSelect_ = value & 0xF000U;
      return WriteResult::Accepted;
    default: return WriteResult::Unmapped;
  }
}

}  // namespace lbpkit::model::hm2
