// SPDX-License-Identifier: MIT
// A quadrature encoder on a motor (or spindle) shaft, wired to one of the
// 7I77's encoder inputs (manual: ENCODER INTERFACE; TB3 encoders 0..2, TB4
// 3..5). It feeds the card's muxed-encoder model, which counts edges
// analytically from a velocity: each plant span sets the velocity that
// brings the signal to the shaft's position at the end of the span, so the
// count is the shaft's at every span's end (piecewise-constant velocity
// within it) while the
// mux path keeps up, and loses counts exactly as that model does when it
// cannot (manual: MAXIMUM ENCODER COUNT RATE).
#pragma once

#include <chrono>
#include <cmath>
#include <cstdint>

#include "hostmot2/muxed_encoder.hpp"
#include "lbp/sim_time.hpp"

namespace lbpkit::model::machine {

using lbp::SimTime;

struct EncoderParameters {
  std::uint32_t linesPerRev = 2000;  // quadrature cycles per revolution: 4x counts
  bool index = true;                 // one index pulse per revolution
  bool reversed = false;             // A and B swapped: counts down when the shaft turns forward

  bool operator==(const EncoderParameters&) const = default;
};

// The encoder's channels, each a differential pair on the 7I77 (manual:
// ENCODER INTERFACE) that a broken wire or connector can take away.
enum class EncoderChannel : std::uint8_t { A, B, Index };

class QuadratureEncoder {
 public:
  // On card input `input`, the shaft at `revs` now.
  QuadratureEncoder(EncoderParameters parameters, hm2::MuxedEncoder& encoders, unsigned input, double revs);

  // Move the signal to the shaft position `revs` at `until`, at constant
  // velocity from `from`: the later of the plant span's start and the time
  // the counter has already been advanced to (the card's time), so the
  // velocity set applies over exactly the time that is left. With less than
  // `minimum` left the signal keeps its velocity and the next span catches
  // up: aiming at the target over a sliver of time would make a velocity
  // spike the counter's filter could drop counts on. `seconds` is
  // until - from in seconds, which the plant works out once a span for all
  // its encoders (a division each saved). Inline: the plant calls it for
  // every encoder at every span.
  void drive(double revs, SimTime from, SimTime until, double seconds, SimTime minimum) {
    if (broken(EncoderChannel::A) || broken(EncoderChannel::B)) return;
    const double target = trueCounts(revs);
    const hm2::EncoderSignal& signal = encoders_->signal(input_);
    if (signal.velocity == 0.0 && std::abs(target - signal.position) < kAtRest) return;
    if (until - from < minimum) return;
    encoders_->advance(from);
    // The signal where the counter is at `from` (signal() settles the counters).
    const double error = target - encoders_->signal(input_).position;
    encoders_->setVelocity(input_, std::abs(error) < kAtRest ? 0.0 : error / seconds, from);
  }

  // The signal stands where a shaft at `revs` puts it (drive() would do
  // nothing), or cannot move (A or B broken).
  [[nodiscard]] bool restsAt(double revs) const {
    if (broken(EncoderChannel::A) || broken(EncoderChannel::B)) return true;
    const hm2::EncoderSignal& signal = encoders_->signal(input_);
    return signal.velocity == 0.0 && std::abs(trueCounts(revs) - signal.position) < kAtRest;
  }

  // A broken channel (a fault to rehearse). With A or B gone the
  // counter sees one channel toggle alone, up one count and back, and no
  // longer follows the shaft: the signal stays where it is. Mended, it goes
  // on from there; the motion in between is lost, as on the machine (the
  // model's index moves with the count: home again after a repair). With
  // the index gone no index pulse comes. `revs`: the shaft now; `now`: the
  // card's time.
  void setBroken(EncoderChannel channel, bool broken, double revs, SimTime now);
  [[nodiscard]] bool broken(EncoderChannel channel) const {
    return (broken_ >> static_cast<unsigned>(channel)) & 1U;
  }
  // A and B swapped at the connector, or the encoder mounted the other way
  // (a fault to rehearse, on top of parameters().reversed): the count runs
  // the other way from the motion, and a position loop closed through it
  // is positive feedback, the runaway the manual warns of (manual: CAUTION,
  // "motor position versus analog output drive"). The count goes on from
  // where it is: trueCounts(revs), with the shaft at `revs` (the plant's,
  // at its time), keeps its value across the change, so nothing jumps. The
  // index stays at its shaft angle.
  void setReversed(bool reversed, double revs);
  [[nodiscard]] bool reversed() const { return swapped_; }

  [[nodiscard]] std::uint32_t countsPerRev() const { return 4 * p_.linesPerRev; }
  // Counts the shaft is at: what a perfect counter would show.
  [[nodiscard]] double trueCounts(double revs) const {
    return origin_ + direction() * revs * static_cast<double>(countsPerRev());
  }
  // The same from the shaft's revolution 0 (the count a counter cleared there shows).
  [[nodiscard]] double shaftCounts(double revs) const { return trueCounts(revs) - origin_; }
  // The count register of the card's counter (16 bits, as the host reads it).
  [[nodiscard]] std::uint16_t count() const { return encoders_->count(input_); }
  // The signal's position (counts) as the counter's input sees it.
  [[nodiscard]] double signalCounts() const { return encoders_->signal(input_).position; }
  [[nodiscard]] unsigned input() const { return input_; }
  [[nodiscard]] const EncoderParameters& parameters() const { return p_; }

 private:
  // Counts per shaft revolution's sign: -1 when reversed by the
  // description or by the fault, not both.
  [[nodiscard]] double direction() const { return p_.reversed != swapped_ ? -1.0 : 1.0; }
  // The counter's index pulses where indexAt_ says, if the encoder has an
  // index and it is not broken.
  void placeIndex();

  // Within this of the shaft, a standing signal stays put: a shaft at rest
  // costs the counters nothing.
  static constexpr double kAtRest = 1e-6;  // counts

  EncoderParameters p_;
  hm2::MuxedEncoder* encoders_;
  unsigned input_;
  double origin_;  // signal counts at shaft revolution 0
  // Where along the signal the index pulses come (modulo countsPerRev):
  // the index track is fixed to the shaft, so this moves as the A/B count
  // slips against the shaft (counts missed while a channel was broken) and
  // when the count is reversed.
  double indexAt_ = 0.0;
  std::uint8_t broken_ = 0;  // bit per EncoderChannel
  bool swapped_ = false;     // setReversed
};

}  // namespace lbpkit::model::machine
