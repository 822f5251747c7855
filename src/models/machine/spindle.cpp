// SPDX-License-Identifier: MIT
#include "machine/spindle.hpp"

#include <algorithm>
#include <cmath>

namespace lbpkit::model::machine {

void Spindle::step(double volts, bool enaOn, double h) {
  // Stopped VFDs ramp down to zero too (no coasting: the usual ramp-stop setting).
  command_ = 0.0;
  if (running(enaOn) && std::abs(volts) > p_.deadbandVolts)
    command_ = std::clamp(volts * p_.rpmPerVolt, -p_.maxRpm, p_.maxRpm);
  // The ramp at the VFD's acceleration until the speed reaches the
  // command, then the command: exact over any span.
  const double rpm0 = rpm_;
  const double gap = command_ - rpm0;
  const double ramp = p_.accelerationRpmPerSecond > 0 ? std::abs(gap) / p_.accelerationRpmPerSecond : 0.0;
  if (ramp >= h) {
    rpm_ = rpm0 + std::copysign(p_.accelerationRpmPerSecond * h, gap);
    revs_ += (rpm0 + rpm_) / 2.0 / 60.0 * h;
  } else {
    rpm_ = command_;
    revs_ += ((rpm0 + command_) / 2.0 * ramp + command_ * (h - ramp)) / 60.0;
  }
}

}  // namespace lbpkit::model::machine
