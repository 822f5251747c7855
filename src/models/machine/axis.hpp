// SPDX-License-Identifier: MIT
// One machine axis behind the 7I77: the motor(s) and the load they move
// through a leadscrew or gearing. Its motion under its drives is solved
// exactly in simulated time by ServoMotion (servo_motion.hpp; no wall
// clock: the same commands give the same motion every run).
//
// Motion is in motor revolutions; machine units (mm, or degrees for a rotary
// axis) are motor revolutions times unitsPerMotorRev. Friction and gravity
// are given at the motor shaft, as a servo tuning sees them.
#pragma once

#include <numbers>

namespace lbpkit::model::machine {

// Radians in a revolution: the axes integrate in rad/s, and speak of
// motor revolutions.
inline constexpr double kTwoPi = 2.0 * std::numbers::pi;

struct AxisParameters {
  double inertia = 3.5e-4;     // kg m^2 at the motor: rotors, screw, coupling and the reflected load
  double viscous = 1e-3;       // Nm per rad/s at the motor
  double coulomb = 0.3;        // Nm at the motor (also the breakaway torque)
  double gravityTorque = 0.0;  // Nm at the motor pulling towards negative positions (a vertical axis)
  double brakeTorque = 0.0;    // Nm the brake holds when engaged
  double unitsPerMotorRev = 5.0;  // screw pitch over gear ratio: machine units per motor revolution
  double hardStopMin = -1e9;   // machine units: the mechanics end here (the axis stops dead)
  double hardStopMax = 1e9;

  bool operator==(const AxisParameters&) const = default;
};

// The inertia a mass adds at the motor through a screw of `mmPerMotorRev`
// per motor revolution: m (lead / 2 pi)^2.
[[nodiscard]] double reflectedInertia(double massKg, double mmPerMotorRev);
// The torque gravity puts on the motor of a vertical axis carrying massKg.
[[nodiscard]] double gravityTorque(double massKg, double mmPerMotorRev);

class Axis {
 public:
  Axis(AxisParameters parameters, double position);

  // Faults a commissioning user rehearses. An outside force (a
  // hand on the table, a collision) moves the axis by `distance` machine
  // units at `speed` units per second (above 0; else invalid_argument),
  // whatever the motors do; then it lets go, leaving the axis at rest. A
  // new push replaces one under way. The hard stops still stop it (and end
  // the push).
  void push(double distance, double speed);
  // A crash or a seized screw: the axis cannot move (a push waits) until
  // released.
  void setJammed(bool jammed);
  [[nodiscard]] bool jammed() const { return jammed_; }
  [[nodiscard]] bool pushing() const { return pushLeft_ != 0.0; }

  [[nodiscard]] double position() const { return revs_ * p_.unitsPerMotorRev; }  // machine units
  [[nodiscard]] double velocity() const { return speed_ * p_.unitsPerMotorRev; }  // machine units per second
  [[nodiscard]] double motorRevs() const { return revs_; }
  [[nodiscard]] double motorRevsPerSecond() const { return speed_; }
  [[nodiscard]] bool atHardStop() const { return stopped_; }
  [[nodiscard]] const AxisParameters& parameters() const { return p_; }

 private:
  friend class ServoMotion;  // moves it
  AxisParameters p_;
  double revs_;
  double speed_ = 0.0;  // rev/s
  bool stopped_ = false;
  bool jammed_ = false;
  double pushLeft_ = 0.0;   // machine units still to push (signed)
  double pushSpeed_ = 0.0;  // machine units per second
};

}  // namespace lbpkit::model::machine
