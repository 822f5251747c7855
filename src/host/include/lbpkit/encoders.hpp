// SPDX-License-Identifier: MIT
// The card's muxed quadrature counters as a driver uses them: 16-bit counts
// extended to 64 bits, position with a scale, velocity from the count
// timestamps, and index enable (latch on the next index, just once).
#pragma once

#include <array>
#include <cstdint>

#include "lbpkit/hostmot2.hpp"
#include "lbpkit/transport.hpp"

namespace lbpkit {

class MuxedEncoders {
 public:
  static constexpr unsigned kMax = 16;
  // Every counter the card's IDROM declares, or the first `used` of them
  // (as LinuxCNC's num_encoders): each one read costs two register reads a
  // cycle. More than the card has is an Error naming both.
  static constexpr unsigned kAll = ~0U;
  MuxedEncoders(Transport& t, const CardInfo& card, unsigned used = kAll);

  [[nodiscard]] unsigned size() const { return count_; }
  // Writes the control registers, the timestamp divisor and the mux rate.
  void initialize();
  // Per cycle: queue the reads (and any control changes); after the flush, update().
  void queue();
  // Returns false, changing nothing, when an exchange failed since queue()
  // (the transport's linkCounters() tell): the registers may be stale, and a
  // velocity from them would be wrong. The next fresh update takes the whole
  // count change since, timed by the card's timestamps.
  bool update();

  [[nodiscard]] std::int64_t counts(unsigned n) const { return state_.at(n).counts - state_.at(n).offset; }
  [[nodiscard]] double position(unsigned n) const { return static_cast<double>(counts(n)) / state_.at(n).scale; }
  [[nodiscard]] double velocity(unsigned n) const { return state_.at(n).velocity / state_.at(n).scale; }
  void setScale(unsigned n, double countsPerUnit) { state_.at(n).scale = countsPerUnit == 0 ? 1 : countsPerUnit; }
  // Index enable: on the next index the count is zeroed there; it clears
  // itself when that happened.
  void enableIndex(unsigned n);
  [[nodiscard]] bool indexEnabled(unsigned n) const { return state_.at(n).indexArmed; }
  [[nodiscard]] std::uint32_t control(unsigned n) const { return state_.at(n).ccr; }

 private:
  // Register `block` (wire::qcount::reg) of counter `counter`.
  [[nodiscard]] std::uint16_t reg(unsigned block, unsigned counter) const;
  struct State {
    std::uint32_t countReg = 0, ccr = 0;
    std::uint16_t lastRaw = 0, lastTimestamp = 0;
    std::int64_t counts = 0, offset = 0;
    double velocity = 0, scale = 1;
    Nanoseconds lastChange{0};
    bool indexArmed = false, writeControl = false, first = true;
    bool controlQueued = false;  // written in the exchange update() has not yet seen succeed
    std::uint32_t controlOut = 0;
  };
  Transport& t_;
  std::uint16_t base_;
  std::uint32_t regStride_;
  std::uint32_t instanceStride_ = 4;
  std::uint32_t clock_;
  unsigned count_;
  std::uint32_t timestamp_ = 0;
  std::uint32_t tsDivisor_;
  std::array<State, kMax> state_{};
  std::uint64_t failuresAtQueue_ = 0;  // the transport's failed exchanges when queue() ran
};

}  // namespace lbpkit
