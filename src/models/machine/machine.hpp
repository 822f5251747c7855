// SPDX-License-Identifier: MIT
// A machine behind one 7I77's terminals: axes with servo
// amplifiers on the analog outputs and drive enables, encoders on the
// card's muxed counters, switches on the field inputs, a spindle on AOUT5 +
// ENA5, and field outputs that drive a coolant pump, a lube pump, a brake.
// An axis may instead be a stepper on one of the card's StepGens
// (StepperMotor), which goes where the StepGen's steps put it. On the
// 7I77+7I76 firmwares switches, outputs, brakes and the spindle (its VFD on
// SpinOut, SpinEna and SpinDir; its encoder on muxed counter 6) may be on
// the 7I76's terminals instead (Daughtercard).
// Built from a MachineDescription (machine_file.hpp) and wired to a
// hm2::HostMot2Card, which must outlive it.
//
// advance(now) moves the plant to `now` in simulated time, in spans of at
// most the description's `step` (1 ms by default): each span takes the
// 7I77's outputs as they are at its start, solves the servo axes exactly
// over it (ServoMotion: events such as a drive saturating or friction
// stopping an axis are found within it), ramps the spindle, steps the
// steppers, sets the switches' inputs from where the axes are at its end,
// and sets each encoder's velocity so its signal reaches the shaft's
// position at the span's end. Call it after the host's cycle, with the time
// of the next one, before the card is advanced past this one: the counters
// then read the shafts' positions exactly when the host next reads them.
// Where the card has already run ahead (the host's accesses advance it),
// each encoder aims at the span's end from where the counter is, so no
// error adds up.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "hostmot2/card.hpp"
#include "machine/axis.hpp"
#include "machine/machine_file.hpp"
#include "machine/quadrature_encoder.hpp"
#include "machine/servo_amplifier.hpp"
#include "machine/servo_motion.hpp"
#include "machine/spindle.hpp"
#include "machine/stepper_motor.hpp"
#include "machine/switches.hpp"

namespace lbpkit::model::machine {

class Machine {
 public:
  // What an observer sees of the machine (the API and tests compare these).
  struct State {
    struct Drive {
      unsigned analogOutput = 0;
      double commandVolts = 0.0;  // at AOUTn
      bool enaOn = false;         // the ENAn switch
      bool enabled = false;       // the amplifier, after its enable wiring
      double torque = 0.0;        // Nm the motor gives at the end of the plant's last span
      unsigned encoderInput = 0;
      std::uint16_t encoderCount = 0;  // the card's count register
      double trueCounts = 0.0;         // where a perfect counter would be (from shaft revolution 0)
      std::vector<EncoderChannel> encoderBroken;  // channels cut (setEncoderBroken)
      bool encoderReversed = false;               // setEncoderReversed
      bool enableIgnored = false;                 // setEnableIgnored
      // When ENAn last changed, as the plant met it (at the start of the
      // span it first held over, so within a span of the change; 0 if never):
      // how long the analog watchdog took to drop it, read after the fact
      // (manual: ANALOG SECTION WATCHDOG).
      SimTime enaChangedAt{};
      bool operator==(const Drive&) const = default;
    };
    // A stepper axis' motor (StepperMotor): the StepGen's steps since the
    // machine was built, those the motor did not follow, and whether it is
    // out of step now.
    struct Stepper {
      unsigned stepGen = 0;
      std::int64_t steps = 0;
      std::int64_t lostSteps = 0;
      bool stalled = false;
      bool operator==(const Stepper&) const = default;
    };
    struct Axis {
      std::string name;
      double position = 0.0;  // machine units (mm)
      double velocity = 0.0;  // machine units per second
      bool brakeEngaged = false;
      bool atHardStop = false;
      bool jammed = false;
      bool pushing = false;
      double commandVelocity = 0.0;  // what drive 0's amplifier asks for, machine units per second
      double followingError = 0.0;   // followingError(axis)
      std::vector<Drive> drives;
      std::optional<Stepper> stepper;  // a stepper axis (no drives)
      std::vector<Switches::State> switches;  // the switches on this axis
      bool operator==(const Axis&) const = default;
    };
    struct Spindle {
      Daughtercard daughtercard = Daughtercard::SevenI77;  // the VFD's
      double commandRpm = 0.0;
      double rpm = 0.0;
      double revolutions = 0.0;
      bool running = false;  // the VFD's run input
      std::optional<std::uint16_t> encoderCount;
      std::vector<EncoderChannel> encoderBroken;
      bool encoderReversed = false;
      bool operator==(const Spindle&) const = default;
    };
    struct Output {
      std::string name;
      unsigned output = 0;
      bool on = false;
      Daughtercard daughtercard = Daughtercard::SevenI77;
      bool operator==(const Output&) const = default;
    };
    std::string name;  // the description's
    SimTime time{};    // the plant's own time: that of the last advance
    std::vector<Axis> axes;
    std::optional<Spindle> spindle;
    bool estopOk = true;  // the E-stop chain is closed
    bool probe = false;   // the probe is tripped
    std::vector<Switches::State> switches;  // every switch, in description order
    std::vector<Output> outputs;
    bool operator==(const State&) const = default;
  };

  // The machine on the 7I77 on `connector` of `card` (and on the card's
  // 7I76, for what the description wires to one), at `now`. Throws
  // std::invalid_argument for wiring the 7I77 does not have, or 7I76 wiring
  // on a card whose firmware has no 7I76 (naming the machine file's key
  // where the description came from one: sevenI76Where).
  Machine(MachineDescription description, hm2::HostMot2Card& card, SimTime now = SimTime{0}, unsigned connector = 0);
  // One machine drives the card's encoders and inputs: no copies.
  Machine(const Machine&) = delete;
  Machine& operator=(const Machine&) = delete;

  void advance(SimTime now);
  // Nothing in the machine moves, or will while the 7I77's outputs stay as
  // they are: every servo axis at rest with its drives off and held
  // (ServoMotion::restsUnpowered, its last span solved so), no stepper
  // axis, the spindle stopped and not asked to run, every encoder's signal
  // standing. advance() then moves the plant's time in one go: an idle
  // machine costs this check an advance.
  [[nodiscard]] bool resting() const;
  // With less of a span left than this after the card's time, an encoder
  // keeps its velocity and the next span catches up (QuadratureEncoder::drive).
  static constexpr SimTime kEncoderMinimumSpan = std::chrono::microseconds(25);

  // Trip or release a switch by name ("estop" pressed, "probe" touching, or
  // any switch stuck); it holds until released. False if there is no such switch.
  bool setSwitch(const std::string& name, bool tripped);
  // The same for every switch of a kind (the E-stop chain's buttons, the
  // probes); how many there are.
  std::size_t setSwitches(SwitchKind kind, bool tripped);

  // Faults to rehearse, on axis `axis` (an index; see axisIndex):
  // an outside force pushing it (Axis::push), a jam (Axis::setJammed), a
  // broken encoder channel of drive `drive` (QuadratureEncoder::setBroken),
  // that encoder's A and B swapped (QuadratureEncoder::setReversed: the
  // count goes on from where it is, the other way), or that drive's
  // amplifier ignoring its enable input (ServoAmplifier::setEnableIgnored:
  // it runs whatever ENA says). The card's time is now. Out of range:
  // std::out_of_range (a stepper axis has no drives). A stepper axis
  // cannot be pushed (std::invalid_argument); jammed, it loses its steps.
  void push(std::size_t axis, double distance, double speed);
  void setJammed(std::size_t axis, bool jammed);
  void setEncoderBroken(std::size_t axis, std::size_t drive, EncoderChannel channel, bool broken);
  void setEncoderReversed(std::size_t axis, std::size_t drive, bool reversed);
  void setEnableIgnored(std::size_t axis, std::size_t drive, bool ignored);
  // The spindle's encoder; false when there is none.
  bool setSpindleEncoderBroken(EncoderChannel channel, bool broken);
  bool setSpindleEncoderReversed(bool reversed);
  [[nodiscard]] std::optional<std::size_t> axisIndex(std::string_view name) const;
  [[nodiscard]] std::size_t drives(std::size_t axis) const { return axes_.at(axis).drives.size(); }

  // What the amplifier of the axis' first drive asks of it: its velocity
  // command in machine units per second (0 while disabled, or in torque
  // mode), and the following error, the position that command asked for
  // (integrated over the plant's spans since the drive was enabled) less
  // where the axis is (0 while disabled). For a stepper axis: the StepGen's
  // commanded rate, and where its steps say the axis is less where it is
  // (the steps the motor lost).
  [[nodiscard]] double commandVelocity(std::size_t axis) const;
  [[nodiscard]] double followingError(std::size_t axis) const;

  // One row of the servo-cycle trace: time_s, then per axis
  // <a>_command_volts, <a>_command_velocity, <a>_position, <a>_velocity,
  // <a>_following_error (drive 0's amplifier) and, on a servo axis,
  // <a>_enabled (1 while drive 0's amplifier is enabled, after its enable
  // polarity and setEnableIgnored; else 0), then spindle_rpm with a
  // spindle. traceRow fills `row` (traceColumns().size() values) without
  // allocating: it is taken on the card thread at every host cycle.
  [[nodiscard]] std::vector<std::string> traceColumns() const;
  void traceRow(std::span<double> row) const;

  [[nodiscard]] State state() const;
  [[nodiscard]] SimTime time() const { return time_; }
  [[nodiscard]] const MachineDescription& description() const { return d_; }
  [[nodiscard]] std::size_t axes() const { return axes_.size(); }
  [[nodiscard]] const Axis& axis(std::size_t i) const { return axes_.at(i).axis; }
  // A stepper axis' motor; nullptr for a servo axis. (Its position is the
  // axis' own: axis(i) has only its faults.)
  [[nodiscard]] const StepperMotor* stepper(std::size_t i) const {
    return axes_.at(i).stepper ? &*axes_.at(i).stepper : nullptr;
  }
  // Where the axis is, in machine units, and how fast it moves: a servo
  // axis' mechanics or a stepper's motor.
  [[nodiscard]] double position(std::size_t i) const { return position(axes_.at(i)); }
  [[nodiscard]] const QuadratureEncoder& encoder(std::size_t axis, std::size_t drive = 0) const {
    return axes_.at(axis).drives.at(drive).encoder;
  }
  [[nodiscard]] const Spindle* spindle() const { return spindle_ ? &*spindle_ : nullptr; }
  // A servo axis' exact solution: its events and flows worked out so far.
  [[nodiscard]] const ServoMotion& motion(std::size_t axis) const { return axes_.at(axis).motion; }

 private:
  struct Drive {
    DriveDescription d;
    ServoAmplifier amplifier;
    QuadratureEncoder encoder;
    double torque = 0.0;
    bool ena = false;        // ENAn as the last span met it
    SimTime enaChangedAt{};  // State::Drive::enaChangedAt
  };
  struct AxisPlant {
    Axis axis;
    std::vector<Drive> drives;
    double inertiaShare;  // per drive, for the velocity loops
    int brakeOutput;
    Daughtercard brakeDaughtercard;
    double commanded = 0.0;  // machine units: drive 0's velocity command integrated since enabled
    std::optional<StepperMotor> stepper;  // in place of the drives
    std::optional<QuadratureEncoder> stepperEncoder;  // on the stepper's shaft
    ServoMotion motion;  // the servo axis' exact solution and its kept flows
    // The StepGen's count when last looked at, and the steps it made while
    // its step pin drove nothing (HostMot2Card::stepGenDriven): the motor
    // never saw those.
    std::int64_t stepGenCount = 0;
    std::int64_t stepsUndriven = 0;
  };

  [[nodiscard]] static double position(const AxisPlant& a) {
    return a.stepper ? a.stepper->position() : a.axis.position();
  }
  [[nodiscard]] static double velocity(const AxisPlant& a) {
    return a.stepper ? a.stepper->velocity() : a.axis.velocity();
  }
  // The plant from time_ to t1, the 7I77's outputs constant over it.
  void span(SimTime t1);
  [[nodiscard]] bool brakeEngaged(const AxisPlant& a) const;
  // A field output of either board, and that board's field power.
  [[nodiscard]] bool outputOn(Daughtercard board, unsigned output) const;
  [[nodiscard]] double fieldVoltage(Daughtercard board) const;
  // What the VFD gets: its speed input (volts, negative: reverse) and its
  // run input (ENA or SpinEna, before its enable polarity).
  [[nodiscard]] double spindleVolts() const;
  [[nodiscard]] bool spindleEna() const;
  // Its first drive is a velocity-mode amplifier, enabled.
  [[nodiscard]] bool commandsVelocity(const AxisPlant& a) const;

  MachineDescription d_;
  hm2::HostMot2Card* card_;
  hm2::SevenI77* board_;
  hm2::MuxedEncoder* encoders_;
  hm2::StepGen* stepGens_;  // the firmware's, nullptr when it has none
  remote::SevenI76FieldIo* sevenI76_;  // the firmware's 7I76, nullptr when it has none
  FieldInputs inputs_;  // the switches' boards
  SimTime time_;
  SimTime h_;  // the longest span (the description's step)
  std::vector<AxisPlant> axes_;
  std::vector<double> positions_;  // per axis, for the switches
  Switches switches_;
  std::optional<Spindle> spindle_;
  std::optional<QuadratureEncoder> spindleEncoder_;
};

}  // namespace lbpkit::model::machine
