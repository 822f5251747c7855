// SPDX-License-Identifier: MIT
#include "machine/stepper_motor.hpp"

#include <algorithm>
#include <cmath>

namespace lbpkit::model::machine {

StepperMotor::StepperMotor(StepperParameters parameters, double position, std::int64_t count, double hardStopMin,
                           double hardStopMax)
    : p_(parameters),
      initial_(position),
      origin_(count),
      count_(count),
      lowest_(static_cast<std::int64_t>(std::ceil(
          (parameters.reversed ? position - hardStopMax : hardStopMin - position) * parameters.stepsPerUnit))),
      highest_(static_cast<std::int64_t>(std::floor(
          (parameters.reversed ? position - hardStopMin : hardStopMax - position) * parameters.stepsPerUnit))) {}

double StepperMotor::unitsPerStep() const { return (p_.reversed ? -1.0 : 1.0) / p_.stepsPerUnit; }

double StepperMotor::position() const { return initial_ + static_cast<double>(moved_) * unitsPerStep(); }

double StepperMotor::commandedPosition() const {
  return initial_ + static_cast<double>(count_ - origin_) * unitsPerStep();
}

void StepperMotor::step(std::int64_t count, double commandedRate, bool held) {
  const std::int64_t made = count - count_;
  count_ = count;
  // Out of step while the StepGen is told to step faster than the motor
  // follows. Judged by the commanded rate, not by the steps that arrived in
  // this plant span: the plant sees the count only as far as the card has
  // run (machine.cpp), so a host period's steps may arrive in one plant span.
  stalled_ = p_.maxStepRate > 0 && std::abs(commandedRate) > p_.maxStepRate;
  const std::int64_t followed = stalled_ || held ? 0 : std::clamp(moved_ + made, lowest_, highest_) - moved_;
  moved_ += followed;
  // The speed the steps are made at, while the motor follows them.
  const bool following = !stalled_ && !held && followed == made;
  velocity_ = following ? commandedRate * unitsPerStep() : 0.0;
}

}  // namespace lbpkit::model::machine
