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
  origin_ = encoders.signal(input).position - (p_.reversed ? -1.0 : 1.0) * revs * countsPerRev();
  encoders.setIndexPeriod(input, p_.index ? countsPerRev() : 0);
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
    slipped_ += slip;
  }
  encoders_->setIndexPeriod(input_, p_.index && !this->broken(EncoderChannel::Index) ? countsPerRev() : 0,
                            std::llround(slipped_));
}

}  // namespace lbpkit::model::machine
