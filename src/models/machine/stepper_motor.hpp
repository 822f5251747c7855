// SPDX-License-Identifier: MIT
// A stepper motor on an axis, driven by a HostMot2 StepGen's step/dir
// outputs: through its drive, each step the StepGen makes
// turns the motor one (micro)step, so the axis is where the steps put it:
// the steps made since the machine was built over `stepsPerUnit`.
//
// Open loop, as a real stepper is: nothing tells the control when the motor
// has not followed. It does not while the StepGen is commanded to step
// faster than the motor's pull-out rate (the torque it has at that speed is
// less than the load needs): the rotor falls out of step and stalls, and
// every step made meanwhile is lost; it steps again once the rate is back
// at or below the pull-out rate (a real motor needs the lower pull-in rate;
// one figure stands for both here, and acceleration is not modelled). A
// jammed axis, an engaged brake and the hard stops lose steps the same way.
// Lost steps are a position error the StepGen's count (and so LinuxCNC's
// feedback, which is the StepGen's accumulator) never shows.
//
// Simulated time only: the caller gives the count at the end of each plant
// step and the rate register's value then.
#pragma once

#include "machine/quadrature_encoder.hpp"

#include <optional>

#include <cstdint>

namespace lbpkit::model::machine {

struct StepperParameters {
  unsigned stepGen = 0;       // the card's StepGen instance (stepgen.NN)
  double stepsPerUnit = 800;  // StepGen steps per machine unit: full steps x microsteps x gear ratio / pitch
  double maxStepRate = 0.0;   // steps per second the motor follows (pull-out); 0: every rate
  // A step in the StepGen's forward direction moves the axis towards
  // negative positions (the motor or DIR wired the other way): what a
  // configuration with a negative position-scale (SCALE) drives.
  bool reversed = false;
  // An encoder on the motor's shaft (a closed-loop stepper: LinuxCNC's
  // feedback from the encoder, its command a StepGen velocity), counted on
  // the card's muxed encoder `encoderInput`; none when absent. One motor
  // revolution is the axis' screw pitch over its gear ratio.
  std::optional<unsigned> encoderInput{};
  EncoderParameters encoder{};

  bool operator==(const StepperParameters&) const = default;
};

class StepperMotor {
 public:
  // At `position` (machine units) with the StepGen's count at `count`; the
  // mechanics end at the hard stops (machine units).
  StepperMotor(StepperParameters parameters, double position, std::int64_t count, double hardStopMin,
               double hardStopMax);

  // One plant span: the StepGen's count at its end, the rate it is
  // commanded to step at (steps per second, signed), and whether the axis is
  // held (jammed, or its brake engaged).
  void step(std::int64_t count, double commandedRate, bool held);

  [[nodiscard]] double position() const;  // machine units
  // Machine units per second: the commanded rate while the motor follows it.
  [[nodiscard]] double velocity() const { return velocity_; }
  // Where the StepGen's count says the axis is (what the control believes).
  [[nodiscard]] double commandedPosition() const;
  [[nodiscard]] std::int64_t steps() const { return count_ - origin_; }  // the StepGen's, since built
  [[nodiscard]] std::int64_t lostSteps() const { return count_ - origin_ - moved_; }
  [[nodiscard]] bool stalled() const { return stalled_; }
  [[nodiscard]] bool atHardStop() const { return moved_ <= lowest_ || moved_ >= highest_; }
  [[nodiscard]] const StepperParameters& parameters() const { return p_; }

 private:
  // Machine units one step in the StepGen's forward direction moves the axis.
  [[nodiscard]] double unitsPerStep() const;

  StepperParameters p_;
  double initial_;
  std::int64_t origin_;   // the count when built
  std::int64_t count_;    // the count at the last step
  std::int64_t moved_ = 0;  // steps the motor made (followed)
  std::int64_t lowest_, highest_;  // moved_ at the hard stops
  bool stalled_ = false;
  double velocity_ = 0.0;
};

}  // namespace lbpkit::model::machine
