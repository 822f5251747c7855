// SPDX-License-Identifier: MIT
// A spindle on a VFD: speed command from a 7I77 analog output (AOUT5 by
// custom, manual: ANALOG SERVO DRIVE INTERFACE) and run from ENA5, which
// follows SpinEna alone (manual: SERVO ENABLE OUTPUTS). The VFD ramps the
// speed within its acceleration limit; a negative voltage runs it in
// reverse. Its encoder (with index, for spindle sync) is an ordinary
// QuadratureEncoder on the shaft.
#pragma once

#include "machine/servo_amplifier.hpp"

namespace lbpkit::model::machine {

struct SpindleParameters {
  double rpmPerVolt = 2400.0;
  double maxRpm = 24000.0;
  double accelerationRpmPerSecond = 8000.0;  // the VFD's ramp, up and down
  double deadbandVolts = 0.0;
  EnablePolarity enablePolarity = EnablePolarity::ActiveHigh;

  bool operator==(const SpindleParameters&) const = default;
};

class Spindle {
 public:
  explicit Spindle(SpindleParameters parameters) : p_(parameters) {}

  // `h` seconds with `volts` at the VFD's input and its run input switched
  // by ENA, both constant over them.
  void step(double volts, bool enaOn, double h);

  [[nodiscard]] bool running(bool enaOn) const {
    return p_.enablePolarity == EnablePolarity::ActiveHigh ? enaOn : !enaOn;
  }
  [[nodiscard]] double rpm() const { return rpm_; }
  [[nodiscard]] double commandRpm() const { return command_; }
  [[nodiscard]] double revolutions() const { return revs_; }
  [[nodiscard]] const SpindleParameters& parameters() const { return p_; }

 private:
  SpindleParameters p_;
  double rpm_ = 0.0;
  double command_ = 0.0;
  double revs_ = 0.0;
};

}  // namespace lbpkit::model::machine
