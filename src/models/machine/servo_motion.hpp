// SPDX-License-Identifier: MIT
// The motion of a servo axis (Axis) under its drives (ServoAmplifier),
// solved exactly between events rather than stepped.
//
// Between two events everything here is linear: a velocity-mode drive's PI
// loop on the motor's speed, a torque-mode drive's constant torque, the
// axis' inertia, viscous friction and gravity, and Coulomb friction and an
// engaged brake as a constant torque against the motion. So over a span in
// which nothing switches, the state x = (motor revolutions, motor speed in
// rad/s, each drive's integrator) follows x' = A x + c and lands exactly on
// Phi x + Psi c (affine_flow.hpp). The events that switch from one linear
// piece to the next are:
//   - a drive saturating at its peak torque, or leaving it;
//   - a drive's integrator reaching its limit (the peak torque), or turning back;
//   - the axis coming to rest: Coulomb friction (and the brake) stop it
//     dead rather than push it back through zero speed;
//   - a resting axis breaking away, when the other torques exceed what
//     friction and the brake hold;
//   - a hard stop, where the mechanics end and the axis stops dead.
// Each is an affine function of the state that is positive while its piece
// holds; when one has gone negative by the end of a span, its time is found
// (regula falsi on the exact solution, to a nanosecond), the state taken
// there, the piece chosen anew, and the rest of the span solved from there.
// The inputs (the drives' voltages and enables, the brake) are constant
// over a span: the machine starts a new span where they change.
//
// A piece the span comes back into before its end (an event and its
// reverse within one span) is not seen: the machine's span is at most its
// `step` (machine_file.hpp), a millisecond by default.
//
// The flows of the span the plant usually advances by (one seen twice in a
// row) are kept per piece, so a servo period costs a matrix-vector product
// per axis; other spans and the events' searches are solved on the state
// vector alone (AffineFlow::solve). The fixed-step integrator this replaces is the reference the
// tests compare it with (tests/support/fixed_step_plant.hpp).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "machine/affine_flow.hpp"
#include "machine/axis.hpp"
#include "machine/servo_amplifier.hpp"
#include "lbp/sim_time.hpp"

namespace lbpkit::model::machine {

using lbp::SimTime;

inline constexpr std::size_t kMaxDrivesPerAxis = kMaxFlowDimension - 2;

// One drive of the axis over a span: its amplifier, what the 7I77 gives it,
// and the share of the axis' inertia its loop is tuned for. `torque` is set
// to what the motor gives at the span's end.
struct ServoDrive {
  ServoAmplifier* amplifier = nullptr;
  double volts = 0.0;
  bool enaOn = false;
  double inertia = 0.0;
  double torque = 0.0;
};

class ServoMotion {
 public:
  // Moves `axis` over `span` with `drives` (at most kMaxDrivesPerAxis)
  // and the brake engaged or not, all constant over the span.
  void advance(Axis& axis, std::span<ServoDrive> drives, bool brakeEngaged, SimTime span);

  // Whether the axis stays where it is over any span: at rest, not pushed,
  // friction and the brake holding what gravity pulls (or jammed), and
  // every drive off with its loop cleared (driveOff).
  [[nodiscard]] static bool restsUnpowered(const Axis& axis, bool brakeEngaged);
  [[nodiscard]] static bool driveOff(const ServoAmplifier& amplifier, bool enaOn);
  // The last span left the axis resting unpowered: the next ones are not
  // solved while it still does (Machine::resting).
  [[nodiscard]] bool settled() const { return atRestChecked_; }

  // Events found since built, flows worked out (and kept), and spans solved
  // on the vector alone (events' searches, spans of another length): what
  // the benchmarks and tests look at.
  [[nodiscard]] std::uint64_t events() const { return events_; }
  [[nodiscard]] std::uint64_t flowsComputed() const { return flowsComputed_; }
  [[nodiscard]] std::uint64_t spansSolved() const { return solved_; }

 private:
  struct Cached {
    std::uint64_t key = ~std::uint64_t{0};
    SimTime span{-1};
    AffineFlow flow;
  };
  // The kept flow of a piece over a span, or nullptr; keep one (the
  // oldest kept goes).
  [[nodiscard]] const AffineFlow* cached(std::uint64_t key, SimTime span) const;
  void keep(std::uint64_t key, SimTime span, const AffineFlow& flow);

  std::array<Cached, 4> cache_{};
  std::size_t nextSlot_ = 0;
  std::uint64_t events_ = 0;
  std::uint64_t flowsComputed_ = 0;
  std::uint64_t solved_ = 0;
  SimTime lastSpan_{-1};
  // The last span ended resting unpowered (restsUnpowered): the next ones
  // need not be solved while it still does.
  bool atRestChecked_ = false;
};

}  // namespace lbpkit::model::machine
