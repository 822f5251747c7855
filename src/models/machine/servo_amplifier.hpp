// SPDX-License-Identifier: MIT
// A servo amplifier behind one 7I77 analog output and one drive enable
// (manual: ANALOG SERVO DRIVE INTERFACE, SERVO ENABLE OUTPUTS).
//
// The 7I77's AOUTn drives the amplifier's differential input, and ENAn (a
// floating opto switch: ENA0..4 follow AnalogEna together, ENA5 follows
// SpinEna) its enable input, wired active-high (ENAn+ to the supply, ENAn- to
// the enable) or active-low (ENAn+ to the enable, ENAn- to ground). A
// velocity-mode drive closes its own velocity loop around the motor; a
// torque-mode drive turns volts into motor torque. Not a model of any one
// drive: the few parameters a servo tuning sees.
#pragma once

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lbp/sim_time.hpp"

namespace lbpkit::model::machine {

using lbp::SimTime;

enum class AmplifierMode { Velocity, Torque };
// Which state of the ENA switch enables the drive (manual: SERVO ENABLE
// OUTPUTS). With active-low wiring the drive runs when the 7I77 is
// unpowered or its analog watchdog has bitten, as on a real machine so wired.
enum class EnablePolarity { ActiveHigh, ActiveLow };

struct AmplifierParameters {
  AmplifierMode mode = AmplifierMode::Velocity;
  double gain = 5.0;            // velocity mode: motor rev/s per volt; torque mode: Nm per volt
  double limit = 55.0;          // saturation of the command: rev/s (velocity) or Nm (torque)
  double deadbandVolts = 0.0;   // inputs closer to 0 V than this command nothing
  double offsetVolts = 0.0;     // the drive's input offset, added to what the 7I77 puts out
  double peakTorque = 7.0;      // velocity mode: Nm the drive's loop may ask of the motor
  double bandwidthHz = 100.0;   // velocity mode: the drive's velocity loop (PI)
  EnablePolarity enablePolarity = EnablePolarity::ActiveHigh;
  // The motor turns the other way for a positive input (its leads, or the
  // drive's direction setting, the other way round): what a configuration
  // with a negative OUTPUT_SCALE drives.
  bool reversed = false;

  bool operator==(const AmplifierParameters&) const = default;
};

class ServoAmplifier {
 public:
  explicit ServoAmplifier(AmplifierParameters parameters) : p_(parameters) {}

  // Whether the drive is enabled, from the state of its ENA switch.
  [[nodiscard]] bool enabled(bool enaOn) const {
    if (enableIgnored_) return true;
    return p_.enablePolarity == EnablePolarity::ActiveHigh ? enaOn : !enaOn;
  }
  // A fault to rehearse: the enable input does nothing (a jumpered or
  // miswired enable), so the drive runs whatever its ENA switch says,
  // following its analog input. The host taking its command to 0 V, or
  // the 7I77's watchdog doing so when the host stops (manual: ANALOG
  // SECTION WATCHDOG), then holds the motor at a standstill rather than
  // letting it go; only an E-stop circuit that removes servo power stops
  // such a drive (manual: CAUTION, "NEVER depend on software commands to
  // disable a motor"; the watchdog "is not a replacement for ESTOP").
  void setEnableIgnored(bool ignored) { enableIgnored_ = ignored; }
  [[nodiscard]] bool enableIgnored() const { return enableIgnored_; }
  // The command the drive makes of `volts` at its input: rev/s or Nm, after
  // offset, deadband and saturation.
  [[nodiscard]] double command(double volts) const {
    const double v = volts + p_.offsetVolts;
    if (std::abs(v) <= p_.deadbandVolts) return 0.0;
    // The deadband is taken out of the input, so the command is continuous
    // just past it.
    const double past = v > 0 ? v - p_.deadbandVolts : v + p_.deadbandVolts;
    const double c = std::clamp(past * p_.gain, -p_.limit, p_.limit);
    return p_.reversed ? -c : c;
  }
  // Velocity mode: the PI loop's gains for a motor moving `inertia`
  // (kg m^2, its share of the axis): proportional inertia x bandwidth
  // (Nm per rad/s), integral a quarter of the bandwidth above it (Nm per
  // rad), so the loop closes at the drive's bandwidth whatever the load.
  // The loop's output and its integrator are each limited to the peak
  // torque (no wind-up past it). ServoMotion solves the loop with the axis.
  struct Gains {
    double kp = 0.0;
    double ki = 0.0;
  };
  [[nodiscard]] Gains gains(double inertia) const {
    const double wc = 2.0 * std::numbers::pi * p_.bandwidthHz;
    return {inertia * wc, inertia * wc * wc / 4.0};
  }
  // The loop's integrator (Nm): 0 while disabled, as a drive clears it
  // when its enable drops.
  [[nodiscard]] double integral() const { return integral_; }
  // The velocity command (rev/s) of the last span the axis moved over: 0
  // when the drive was disabled or is in torque mode.
  [[nodiscard]] double lastVelocityCommand() const { return velocityCommand_; }

  [[nodiscard]] const AmplifierParameters& parameters() const { return p_; }

 private:
  friend class ServoMotion;  // integrates the loop
  AmplifierParameters p_;
  double integral_ = 0.0;  // Nm, the velocity loop's integrator
  double velocityCommand_ = 0.0;
  bool enableIgnored_ = false;
};

}  // namespace lbpkit::model::machine
