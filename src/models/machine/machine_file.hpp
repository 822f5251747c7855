// SPDX-License-Identifier: MIT
// A machine behind the 7I77's terminals, described as plain data: which
// analog output, drive enable and encoder input each motor is wired to, the
// amplifiers, motors, loads and screws, the switches on the field inputs
// and the field outputs that drive things. On the 7I77+7I76 firmwares
// switches, outputs, a brake and the spindle may be on the 7I76's terminals
// instead (Daughtercard). Three built-ins: mill(),
// lathe(), gantry() (docs/machine-mill.md has the mill's wiring as
// LinuxCNC names the pins). Machine files are these in TOML:
// config::loadMachine (src/config/config/machine_toml.hpp) reads them, and
// examples/machines/mill.toml documents the schema; mill.toml, lathe.toml
// and gantry.toml there load to exactly these built-ins (tests hold them
// equal, so a change here goes there too).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "lbp/sim_time.hpp"
#include "machine/axis.hpp"
#include "machine/daughtercard.hpp"
#include "machine/quadrature_encoder.hpp"
#include "machine/servo_amplifier.hpp"
#include "machine/spindle.hpp"
#include "machine/stepper_motor.hpp"
#include "machine/switches.hpp"

namespace lbpkit::model::machine {

// One motor on an axis: its amplifier on AOUTn/ENAn (manual: ANALOG SERVO
// DRIVE INTERFACE, SERVO ENABLE OUTPUTS) and its encoder (ENCODER INTERFACE).
struct DriveDescription {
  unsigned analogOutput = 0;  // AOUT0..5
  unsigned enable = 0;        // ENA0..5 (ENA0..4 follow AnalogEna, ENA5 SpinEna)
  AmplifierParameters amplifier;
  double motorInertia = 1.5e-4;  // kg m^2, the rotor
  unsigned encoderInput = 0;     // the card's muxed encoder 0..5 (7I77 TB3/TB4)
  EncoderParameters encoder;

  bool operator==(const DriveDescription&) const = default;
};

struct AxisDescription {
  std::string name;                     // "x"
  std::vector<DriveDescription> drives;  // one, or two for a gantry (rigidly coupled); none for a stepper
  // A stepper on a StepGen in place of the servo drives: the axis
  // goes where the steps put it (stepper_motor.hpp), not where torques do.
  std::optional<StepperParameters> stepper;
  double screwPitch = 5.0;              // mm per screw revolution (machine units are mm: the
                                        // reflected mass and gravity are worked out in them)
  double gearRatio = 1.0;               // motor revolutions per screw revolution
  double massKg = 100.0;                // what the screw moves
  double screwInertia = 1e-4;           // kg m^2 at the motor: screw, coupling, pulleys
  double viscous = 1e-3;                // Nm per rad/s at the motor
  double coulomb = 0.3;                 // Nm at the motor
  bool vertical = false;                // gravity pulls the mass towards negative positions
  double travelMin = 0.0;               // machine units: what the configuration may use
  double travelMax = 100.0;
  double overtravel = 5.0;              // past the travel (and the limit switches): the hard stops
  double initialPosition = 0.0;
  int brakeOutput = -1;                 // field output that releases the brake (off: holding), -1 none
  Daughtercard brakeDaughtercard = Daughtercard::SevenI77;  // whose field output
  double brakeTorque = 0.0;             // Nm at the motor

  [[nodiscard]] double unitsPerMotorRev() const { return screwPitch / gearRatio; }
  bool operator==(const AxisDescription&) const = default;
};

// The VFD on the 7I77 (speed from AOUTn, +-10 V: negative runs it in
// reverse; run from ENAn) or on the 7I76's spindle interface (speed from
// SpinOut, 0..10 V; run from SpinEna; reverse while SpinDir is on, as
// LinuxCNC configurations wire spindle.0.reverse to spindir). Its encoder on
// one of the 7I77's six, or on the 7I76's one spindle encoder input (0).
struct SpindleDescription {
  Daughtercard daughtercard = Daughtercard::SevenI77;
  unsigned analogOutput = 5;  // the 7I77's only
  unsigned enable = 5;        // the 7I77's only; ENA5 follows SpinEna
  SpindleParameters vfd;
  std::optional<unsigned> encoderInput = 5;
  Daughtercard encoderDaughtercard = Daughtercard::SevenI77;
  EncoderParameters encoder{1000, true, false};

  bool operator==(const SpindleDescription&) const = default;
};

// A field output that drives something (a coolant pump contactor, a lube
// pump, a brake): its name and the load it puts on the output.
struct OutputDescription {
  std::string name;
  unsigned output = 0;     // field output 0..15
  double loadOhms = 480;   // a 24 V relay coil: 50 mA
  Daughtercard daughtercard = Daughtercard::SevenI77;

  bool operator==(const OutputDescription&) const = default;
};

struct MachineDescription {
  std::string name;
  std::vector<AxisDescription> axes;
  std::optional<SpindleDescription> spindle;
  std::vector<SwitchParameters> switches;  // axis switches name their axis
  std::vector<OutputDescription> outputs;
  // The longest span the plant solves in one piece (servo_motion.hpp):
  // the 7I77's outputs are looked at, the switches set and the encoders
  // aimed at least this often. The motion itself is exact at any span.
  lbp::SimTime step = lbp::SimTime{1'000'000};
  // Where a machine file first wires the 7I76 ("FILE:LINE:COL: key"), for
  // the machine to point at when the card's firmware has none; empty for
  // descriptions made in code.
  std::string sevenI76Where;

  bool operator==(const MachineDescription&) const = default;
};

// X/Y/Z knee-less mill: docs/machine-mill.md.
[[nodiscard]] MachineDescription mill();
// X (cross slide) and Z (carriage) lathe with a spindle encoder for threading.
[[nodiscard]] MachineDescription lathe();
// A gantry router: Y driven by two motors (AOUT1/ENC1 and AOUT2/ENC2), X, Z.
[[nodiscard]] MachineDescription gantry();

}  // namespace lbpkit::model::machine
