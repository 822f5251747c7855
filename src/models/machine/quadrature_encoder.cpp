#include "machine/quadrature_encoder.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

namespace machine {

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

double QuadratureEncoder::trueCounts(double revs) const {
  return origin_ + (p_.reversed ? -1.0 : 1.0) * revs * static_cast<double>(countsPerRev());
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

void QuadratureEncoder::drive(double revs, SimTime from, SimTime until, SimTime minimum) {
  if (broken(EncoderChannel::A) || broken(EncoderChannel::B)) return;
  // Within this of the shaft, a standing signal stays put: a shaft at rest
  // costs the counters nothing.
  constexpr double kAtRest = 1e-6;  // counts
  const double target = trueCounts(revs);
  const hm2::EncoderSignal& signal = encoders_->signal(input_);
  if (signal.velocity == 0.0 && std::abs(target - signal.position) < kAtRest) return;
  if (until - from < minimum) return;
  encoders_->advance(from);
  const double seconds = std::chrono::duration<double>(until - from).count();
  // The signal where the counter is at `from` (signal() settles the counters).
  const double error = target - encoders_->signal(input_).position;
  encoders_->setVelocity(input_, std::abs(error) < kAtRest ? 0.0 : error / seconds, from);
}

}  // namespace machine
