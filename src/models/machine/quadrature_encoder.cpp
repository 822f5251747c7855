// SPDX-License-Identifier: MIT
#include "machine/quadrature_encoder.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace lbpkit::model::machine {

QuadratureEncoder::QuadratureEncoder(EncoderParameters parameters, hm2::MuxedEncoder& encoders, unsigned input,
                                     double revs)
    : p_(parameters), encoders_(&encoders), input_(input), origin_(0.0) {
  if (input >= encoders.counters()) throw std::invalid_argument("encoder input " + std::to_string(input) + " is not on the card");
  if (p_.linesPerRev == 0) throw std::invalid_argument("an encoder needs at least one line per revolution");
  // The signal goes on from where it is; the counter model puts the index at
  // multiples of countsPerRev of the signal, so it comes once a revolution
  // at a fixed shaft angle, as on a real encoder.
  origin_ = encoders.signal(input).position - direction() * revs * countsPerRev();
  placeIndex();
}

void QuadratureEncoder::setBroken(EncoderChannel channel, bool broken, double revs, SimTime now) {
  constexpr std::uint8_t kCounting = (1U << static_cast<unsigned>(EncoderChannel::A)) |
                                     (1U << static_cast<unsigned>(EncoderChannel::B));
  const bool wasCounting = (broken_ & kCounting) == 0;
  const auto bit = static_cast<std::uint8_t>(1U << static_cast<unsigned>(channel));
  broken_ = static_cast<std::uint8_t>(broken ? broken_ | bit : broken_ & ~bit);
  const bool counting = (broken_ & kCounting) == 0;
  if (wasCounting && !counting) encoders_->setVelocity(input_, 0.0, now);  // stops where it is
  if (!wasCounting && counting) {
    // The counts missed stay missed: the signal goes on from where it stopped.
    encoders_->advance(now);
    const double slip = encoders_->signal(input_).position - trueCounts(revs);
    origin_ += slip;
    indexAt_ += slip;
  }
  placeIndex();
}

void QuadratureEncoder::setReversed(bool reversed, double revs) {
  if (reversed == swapped_) return;
  const double cpr = countsPerRev();
  // The index's shaft angle (revolutions), from where it comes along the signal now.
  const double indexRevs = (indexAt_ - origin_) / (direction() * cpr);
  const double counts = trueCounts(revs);
  swapped_ = reversed;
  origin_ = counts - direction() * revs * cpr;  // trueCounts(revs) is where it was
  indexAt_ = std::fmod(origin_ + direction() * indexRevs * cpr, cpr);
  placeIndex();
}

void QuadratureEncoder::placeIndex() {
  encoders_->setIndexPeriod(input_, p_.index && !broken(EncoderChannel::Index) ? countsPerRev() : 0,
                            std::llround(indexAt_));
}

}  // namespace lbpkit::model::machine
