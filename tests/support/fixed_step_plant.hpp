// SPDX-License-Identifier: MIT
// The fixed-step plant: one servo axis and its drives integrated in small
// equal steps (semi-implicit Euler), the straightforward way. The product
// solves the same equations exactly between events (machine/servo_motion.hpp);
// this is what the tests compare it with, at a step short enough to be
// accurate, and it is nowhere in the product.
//
// The equations, shared by both: a velocity-mode drive is a PI loop on the
// motor's speed with output and integrator limited to its peak torque
// (ServoAmplifier::gains), a torque-mode drive gives its command; the axis
// is inertia, viscous friction, gravity, and Coulomb friction plus an
// engaged brake holding a resting axis until the other torques exceed them
// and stopping a moving one dead rather than pushing it back through zero
// speed; the axis stops dead against its hard stops.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

#include "machine/axis.hpp"
#include "machine/servo_amplifier.hpp"

namespace test_support {

class FixedStepAxis {
 public:
  struct Drive {
    lbpkit::model::machine::AmplifierParameters amplifier;
    double inertia = 0.0;  // its share of the axis' inertia, for its loop's gains
  };

  FixedStepAxis(lbpkit::model::machine::AxisParameters p, std::vector<Drive> drives, double position)
      : p_(p), drives_(std::move(drives)), integral_(drives_.size(), 0.0), revs_(position / p.unitsPerMotorRev) {}

  // `seconds` in steps of `h`, each drive's input volts and ENA switch constant.
  void run(const std::vector<double>& volts, const std::vector<bool>& ena, bool brake, double seconds, double h) {
    const auto steps = static_cast<long>(std::llround(seconds / h));
    for (long s = 0; s < steps; ++s) step(volts, ena, brake, h);
  }

  [[nodiscard]] double position() const { return revs_ * p_.unitsPerMotorRev; }
  [[nodiscard]] double velocity() const { return speed_ * p_.unitsPerMotorRev; }
  [[nodiscard]] double integral(std::size_t drive) const { return integral_.at(drive); }

 private:
  void step(const std::vector<double>& volts, const std::vector<bool>& ena, bool brake, double h) {
    double torque = 0.0;
    for (std::size_t i = 0; i < drives_.size(); ++i) {
      const lbpkit::model::machine::ServoAmplifier amp(drives_[i].amplifier);
      if (!amp.enabled(ena[i])) {
        integral_[i] = 0.0;
        continue;
      }
      if (amp.parameters().mode == lbpkit::model::machine::AmplifierMode::Torque) {
        torque += amp.command(volts[i]);
        continue;
      }
      const auto [kp, ki] = amp.gains(drives_[i].inertia);
      const double peak = amp.parameters().peakTorque;
      const double error = lbpkit::model::machine::kTwoPi * (amp.command(volts[i]) - speed_);
      torque += std::clamp(kp * error + integral_[i], -peak, peak);
      integral_[i] = std::clamp(integral_[i] + ki * error * h, -peak, peak);
    }
    const double w0 = lbpkit::model::machine::kTwoPi * speed_;
    const double holding = p_.coulomb + (brake ? p_.brakeTorque : 0.0);
    const double applied = torque - p_.gravityTorque - p_.viscous * w0;
    double w1 = 0.0;
    if (w0 == 0.0) {
      if (std::abs(applied) > holding) w1 = (applied - std::copysign(holding, applied)) * h / p_.inertia;
    } else {
      w1 = w0 + (applied - std::copysign(holding, w0)) * h / p_.inertia;
      if ((w1 > 0) != (w0 > 0)) w1 = 0.0;
    }
    revs_ += (w0 + w1) / 2.0 * h / lbpkit::model::machine::kTwoPi;
    speed_ = w1 / lbpkit::model::machine::kTwoPi;
    const double pos = position(), v = velocity();
    if ((pos <= p_.hardStopMin && v <= 0) || (pos >= p_.hardStopMax && v >= 0)) {
      revs_ = std::clamp(pos, p_.hardStopMin, p_.hardStopMax) / p_.unitsPerMotorRev;
      speed_ = 0.0;
    }
  }

  lbpkit::model::machine::AxisParameters p_;
  std::vector<Drive> drives_;
  std::vector<double> integral_;
  double revs_;
  double speed_ = 0.0;
};

}  // namespace test_support
