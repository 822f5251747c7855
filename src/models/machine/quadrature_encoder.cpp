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

void QuadratureEncoder::drive(double revs, SimTime from, SimTime until, SimTime minimum) {
  // Within this of the shaft, a standing signal stays put: a shaft at rest
  // costs the counters nothing.
  constexpr double kAtRest = 1e-6;  // counts
  const double target = trueCounts(revs);
  const hm2::EncoderSignal& signal = encoders_->signal(input_);
  if (signal.velocity == 0.0 && std::abs(target - signal.position) < kAtRest) return;
  if (until - from < minimum) return;
  encoders_->advance(from);
  const double seconds = std::chrono::duration<double>(until - from).count();
  const double error = target - signal.position;
  encoders_->setVelocity(input_, std::abs(error) < kAtRest ? 0.0 : error / seconds, from);
}

}  // namespace machine
