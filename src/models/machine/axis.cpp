#include "machine/axis.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace machine {

namespace {
constexpr double kTwoPi = 2.0 * std::numbers::pi;
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
    : p_(parameters), revs_(position / (parameters.unitsPerMotorRev != 0 ? parameters.unitsPerMotorRev : 1.0)) {
  if (p_.unitsPerMotorRev == 0) p_.unitsPerMotorRev = 1.0;
}

void Axis::step(double driveTorque, bool brakeEngaged, double h) {
  // Semi-implicit Euler in rad/s. Static and Coulomb friction (and an
  // engaged brake, which is more of the same) hold a standing axis until the
  // other torques exceed them, and stop a moving one dead rather than push
  // it back through zero speed.
  const double w0 = kTwoPi * speed_;
  const double holding = p_.coulomb + (brakeEngaged ? p_.brakeTorque : 0.0);
  const double applied = driveTorque - p_.gravityTorque - p_.viscous * w0;
  double w1 = 0.0;
  if (w0 == 0.0) {
    if (std::abs(applied) > holding) w1 = (applied - std::copysign(holding, applied)) * h / p_.inertia;
  } else {
    w1 = w0 + (applied - std::copysign(holding, w0)) * h / p_.inertia;
    if ((w1 > 0) != (w0 > 0)) w1 = 0.0;  // friction stops it; the next step decides about breakaway
  }
  revs_ += (w0 + w1) / 2.0 * h / kTwoPi;
  speed_ = w1 / kTwoPi;
  // The hard stops: the axis stops dead against them.
  const double pos = position();
  const double lo = p_.hardStopMin, hi = p_.hardStopMax;
  stopped_ = false;
  const double v = velocity();
  if ((pos <= lo && v <= 0) || (pos >= hi && v >= 0)) {
    revs_ = std::clamp(pos, lo, hi) / p_.unitsPerMotorRev;
    speed_ = 0.0;
    stopped_ = true;
  }
}

}  // namespace machine
