// SPDX-License-Identifier: MIT
#include "machine/axis.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace lbpkit::model::machine {

namespace {
constexpr double kGravity = 9.80665;  // m/s^2
}  // namespace

double reflectedInertia(double massKg, double mmPerMotorRev) {
  const double r = mmPerMotorRev / 1000.0 / kTwoPi;  // m per rad
  return massKg * r * r;
}

double gravityTorque(double massKg, double mmPerMotorRev) {
  return massKg * kGravity * mmPerMotorRev / 1000.0 / kTwoPi;
}

Axis::Axis(AxisParameters parameters, double position)
    // By the reciprocal, as the hard stops in revolutions are worked out
    // (ServoMotion): an axis put at a stop is at it.
    : p_(parameters), revs_(position * (1.0 / (parameters.unitsPerMotorRev != 0 ? parameters.unitsPerMotorRev : 1.0))) {
  if (p_.unitsPerMotorRev == 0) p_.unitsPerMotorRev = 1.0;
}

void Axis::push(double distance, double speed) {
  if (!std::isfinite(distance) || !(speed > 0) || !std::isfinite(speed))
    throw std::invalid_argument("a push needs a finite distance and a speed above 0");
  pushLeft_ = distance;
  pushSpeed_ = speed;
}

void Axis::setJammed(bool jammed) {
  jammed_ = jammed;
  if (jammed_) speed_ = 0.0;
}

}  // namespace lbpkit::model::machine
