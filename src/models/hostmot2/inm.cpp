// SPDX-License-Identifier: MIT
#include "hostmot2/inm.hpp"

#include <algorithm>

namespace lbpkit::model::hm2 {

namespace {
constexpr unsigned kDivisorShift = 6, kShortShift = 16, kLongShift = 22;
constexpr std::uint32_t kDivisorMask = 0x3FF, kShortMask = 0x3F, kLongMask = 0x3FF;

// Position of an A/B state (A bit 0, B bit 1) along the forward quadrature
// sequence 00, A, AB, B.
constexpr std::array<unsigned, 4> kPhase = {0, 1, 3, 2};
}  // namespace

InM::InM(std::uint16_t base, unsigned instances, unsigned inputs, std::uint32_t clockLow, std::uint8_t version)
    : Module(kKind, base, std::min(instances, kMaxInstances), version),
      inputs_(std::clamp(inputs, 1U, kMaxInputs)),
      clock_(clockLow) {
  reset();
}

void InM::connect(const IoPort* io, unsigned instance, unsigned input, unsigned port, unsigned bit) {
  source_.at(instance).at(input) =
      Source{io, static_cast<std::uint8_t>(port), static_cast<std::uint8_t>(bit)};
  // A freshly connected input starts settled on what its pin shows.
  const std::uint32_t b = 1U << input;
  filtered_[instance] = (filtered_[instance] & ~b) | (raw(instance) & b);
  pending_[instance] &= ~b;
}

std::uint32_t InM::raw(unsigned instance) const {
  std::uint32_t v = 0;
  for (unsigned n = 0; n < inputs_; ++n) {
    const Source& s = source_[instance][n];
    const bool level = s.io == nullptr || s.io->pin(s.port, s.bit);
    v |= static_cast<std::uint32_t>(level) << n;
  }
  return (control_[instance] & kInvert) != 0 ? ~v & mask() : v;
}

SimTime InM::filterTime(unsigned instance, unsigned n) const {
  const std::uint32_t c = control_.at(instance);
  const std::uint64_t scans = ((filter_[instance] >> n) & 1U) != 0 ? (c >> kLongShift) & kLongMask
                                                                    : (c >> kShortShift) & kShortMask;
  const std::uint64_t divisor = (c >> kDivisorShift) & kDivisorMask;
  // At most 1023 * 4 * 1024 * 32 ticks: times 1e9 still fits 64 bits.
  const std::uint64_t ticks = scans * 4 * (divisor + 1) * inputs_;
  return SimTime{static_cast<SimTime::rep>(ticks * 1'000'000'000ULL / clock_)};
}

void InM::advance(SimTime now) {
  if (now <= now_) return;
  for (unsigned i = 0; i < instances_; ++i) {
    const std::uint32_t differs = raw(i) ^ filtered_[i];
    // A pin seen at a new level now changed after the last look (the world
    // sets pins between the card's advances): its wait starts there. One
    // that went back to its filtered level stops waiting.
    for (std::uint32_t fresh = differs & ~pending_[i]; fresh != 0; fresh &= fresh - 1)
      since_[i][static_cast<unsigned>(__builtin_ctz(fresh))] = now_;
    pending_[i] = differs;
    // Those that kept the new level for their filter time take it, in the
    // order they do (the MPG counters see the edges in that order; edges at
    // the same moment are one step).
    while (pending_[i] != 0) {
      SimTime first = SimTime::max();
      std::uint32_t due = 0;
      for (std::uint32_t p = pending_[i]; p != 0; p &= p - 1) {
        const auto n = static_cast<unsigned>(__builtin_ctz(p));
        const SimTime at = since_[i][n] + filterTime(i, n);
        if (at > now) continue;
        if (at < first) {
          first = at;
          due = 0;
        }
        if (at == first) due |= 1U << n;
      }
      if (due == 0) break;
      const std::uint32_t before = filtered_[i];
      filtered_[i] ^= due;
      pending_[i] &= ~due;
      for (unsigned k = 0; k < kMpgs; ++k) {
        const unsigned from = (before >> (2 * k)) & 3U, to = (filtered_[i] >> (2 * k)) & 3U;
        if (from == to) continue;
        const unsigned d = (kPhase[to] + 4 - kPhase[from]) % 4;  // 1 forward, 3 back, 2 both edges: no count
        const bool fourX = ((mpgMode_[i] >> (8 * k)) & 1U) != 0;
        auto& count = mpg_[i][k];
        // 1X counts one per cycle: forward into 00 from B, back out of 00 into B.
        if (d == 1 && (fourX || to == 0)) ++count;
        if (d == 3 && (fourX || from == 0)) --count;
      }
    }
  }
  now_ = now;
}

std::uint32_t InM::readRegister(std::uint16_t address, SimTime) {
  const unsigned i = (address & 0xFFU) / 4;
  switch (block(address)) {
    case kControl: return (control_[i] & ~kMaxBitMask) | (inputs_ - 1);
    case kFilter: return filter_[i];
    case kFiltered: return filtered_[i];
    case kRaw: return raw(i);
    case kMpg: {
      const auto& m = mpg_[i];
      return std::uint32_t{m[0]} | std::uint32_t{m[1]} << 8 | std::uint32_t{m[2]} << 16 | std::uint32_t{m[3]} << 24;
    }
    default: return 0;
  }
}

WriteResult InM::writeRegister(std::uint16_t address, std::uint32_t value, SimTime) {
  const unsigned i = (address & 0xFFU) / 4;
  switch (block(address)) {
    case kControl: control_[i] = value & ~kMaxBitMask; return WriteResult::Accepted;
    case kFilter: filter_[i] = value & mask(); return WriteResult::Accepted;
    case kMpg: mpgMode_[i] = value & 0x01010101U; return WriteResult::Accepted;
    default: return WriteResult::Unmapped;  // the data registers are read-only in the map
  }
}

void InM::reset() {
  control_.fill(0);
  filter_.fill(0);
  mpgMode_.fill(0);
  pending_.fill(0);
  for (auto& m : mpg_) m.fill(0);
  for (unsigned i = 0; i < instances_; ++i) filtered_[i] = raw(i);
}

InM::State InM::state() const {
  State s;
  s.instances = instances_;
  for (unsigned i = 0; i < instances_; ++i) {
    auto& o = s.instance[i];
    o.inputs = inputs_;
    o.control = (control_[i] & ~kMaxBitMask) | (inputs_ - 1);
    o.filter = filter_[i];
    o.filtered = filtered_[i];
    o.raw = raw(i);
    o.mpgMode = mpgMode_[i];
    o.mpg = mpg_[i];
  }
  return s;
}

}  // namespace lbpkit::model::hm2
