#include "machine/servo_amplifier.hpp"

#include <algorithm>
#include <cmath>

#include "machine/axis.hpp"  // kTwoPi

namespace machine {

double ServoAmplifier::torque(double volts, bool enaOn, double motorRevsPerSecond, double inertia, double h) {
  velocityCommand_ = 0.0;
  if (!enabled(enaOn)) {
    integral_ = 0.0;
    return 0.0;
  }
  if (p_.mode == AmplifierMode::Torque) return command(volts);
  // Velocity mode: a PI loop on the motor's speed, proportional gain from
  // the bandwidth and the inertia it moves, integral corner a quarter of
  // that, both limited to the peak torque (no wind-up past it).
  if (inertia != gainsFor_) {
    const double wc = kTwoPi * p_.bandwidthHz;
    kp_ = inertia * wc;
    ki_ = kp_ * wc / 4.0;
    gainsFor_ = inertia;
  }
  velocityCommand_ = command(volts);
  const double error = kTwoPi * (velocityCommand_ - motorRevsPerSecond);  // rad/s
  const double out = std::clamp(kp_ * error + integral_, -p_.peakTorque, p_.peakTorque);
  integral_ = std::clamp(integral_ + ki_ * error * h, -p_.peakTorque, p_.peakTorque);
  return out;
}

}  // namespace machine
