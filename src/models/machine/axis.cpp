#include "machine/axis.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace machine {

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
    : p_(parameters), revs_(position / (parameters.unitsPerMotorRev != 0 ? parameters.unitsPerMotorRev : 1.0)) {
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

void Axis::step(double driveTorque, bool brakeEngaged, double h) {
  if (jammed_) {
    // Held whatever the torques: no motion, none stored for later.
    speed_ = 0.0;
    return;
  }
  if (pushLeft_ != 0.0) {
    // Kinematic: the outside force wins over the motors, friction and the
    // brake; what it moves, the encoders and switches see as usual.
    const double move = std::copysign(std::min(std::abs(pushLeft_), pushSpeed_ * h), pushLeft_);
    pushLeft_ = std::abs(pushLeft_) <= std::abs(move) ? 0.0 : pushLeft_ - move;
    revs_ += move / p_.unitsPerMotorRev;
    speed_ = pushLeft_ != 0.0 ? move / h / p_.unitsPerMotorRev : 0.0;  // let go: at rest
    const double pos = position();
    stopped_ = pos <= p_.hardStopMin || pos >= p_.hardStopMax;
    if (stopped_) {
      revs_ = std::clamp(pos, p_.hardStopMin, p_.hardStopMax) / p_.unitsPerMotorRev;
      speed_ = 0.0;
      pushLeft_ = 0.0;
    }
    return;
  }
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
