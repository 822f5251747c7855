#include "machine/spindle.hpp"

#include <algorithm>
#include <cmath>

namespace machine {

void Spindle::step(double volts, bool enaOn, double h) {
  // Stopped VFDs ramp down to zero too (no coasting: the usual ramp-stop setting).
  command_ = 0.0;
  if (running(enaOn) && std::abs(volts) > p_.deadbandVolts)
    command_ = std::clamp(volts * p_.rpmPerVolt, -p_.maxRpm, p_.maxRpm);
  const double maxChange = p_.accelerationRpmPerSecond * h;
  const double rpm0 = rpm_;
  rpm_ = rpm0 + std::clamp(command_ - rpm0, -maxChange, maxChange);
  revs_ += (rpm0 + rpm_) / 2.0 / 60.0 * h;
}

}  // namespace machine
