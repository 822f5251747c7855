#include "machine/servo_amplifier.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace machine {

double ServoAmplifier::command(double volts) const {
  const double v = volts + p_.offsetVolts;
  if (std::abs(v) <= p_.deadbandVolts) return 0.0;
  // The deadband is taken out of the input, so the command is continuous
  // just past it.
  const double past = v > 0 ? v - p_.deadbandVolts : v + p_.deadbandVolts;
  return std::clamp(past * p_.gain, -p_.limit, p_.limit);
}

double ServoAmplifier::torque(double volts, bool enaOn, double motorRevsPerSecond, double inertia, double h) {
  if (!enabled(enaOn)) {
    integral_ = 0.0;
    return 0.0;
  }
  if (p_.mode == AmplifierMode::Torque) return command(volts);
  // Velocity mode: a PI loop on the motor's speed, proportional gain from
  // the bandwidth and the inertia it moves, integral corner a quarter of
  // that, both limited to the peak torque (no wind-up past it).
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  const double wc = kTwoPi * p_.bandwidthHz;
  const double kp = inertia * wc;
  const double ki = kp * wc / 4.0;
  const double error = kTwoPi * (command(volts) - motorRevsPerSecond);  // rad/s
  const double out = std::clamp(kp * error + integral_, -p_.peakTorque, p_.peakTorque);
  integral_ = std::clamp(integral_ + ki * error * h, -p_.peakTorque, p_.peakTorque);
  return out;
}

}  // namespace machine
