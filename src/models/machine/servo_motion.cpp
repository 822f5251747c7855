// SPDX-License-Identifier: MIT
#include "machine/servo_motion.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lbpkit::model::machine {

namespace {

// The pieces (servo_motion.hpp).
enum class Motion : std::uint8_t { Forward, Backward, Held };
enum class DriveState : std::uint8_t { Off, Torque, Linear, SaturatedUp, SaturatedDown };
enum class Integrator : std::uint8_t { Free, AtUpper, AtLower };

struct Piece {
  Motion motion = Motion::Held;
  std::array<DriveState, kMaxDrivesPerAxis> drive{};
  std::array<Integrator, kMaxDrivesPerAxis> integrator{};

  [[nodiscard]] std::uint64_t key(std::size_t drives) const {
    std::uint64_t k = static_cast<std::uint64_t>(motion);
    for (std::size_t i = 0; i < drives; ++i)
      k = (k << 5) | (static_cast<std::uint64_t>(drive[i]) << 2) | static_cast<std::uint64_t>(integrator[i]);
    return k;
  }
};

// What an event does before the piece is chosen again.
enum class GuardEvent : std::uint8_t { Rest, HardStop, Switch };

constexpr std::size_t kRevs = 0, kSpeed = 1, kIntegral = 2;  // state indices; drive i's integrator at kIntegral + i
constexpr double kRevsPerRadian = 1.0 / kTwoPi;
// Event searches stop within this of the event (seconds), and a span finds
// at most this many events (the rest of it is solved in the last piece).
constexpr double kEventTolerance = 1e-9;
constexpr int kMaxEventsPerSpan = 64;

// The axis and its drives over one span: the constants the pieces are made of.
class Problem {
 public:
  Problem(const Axis& axis, std::span<ServoDrive> drives, bool brakeEngaged)
      : p_(axis.parameters()), drives_(drives.size()), jammed_(axis.jammed()) {
    // (Products with reciprocals: a span's few divisions are most of its
    // latency.)
    holding_ = p_.coulomb + (brakeEngaged ? p_.brakeTorque : 0.0);
    const double revsPerUnit = 1.0 / p_.unitsPerMotorRev;
    hiRevs_ = p_.hardStopMax * revsPerUnit;
    loRevs_ = p_.hardStopMin * revsPerUnit;
    perInertia_ = 1.0 / p_.inertia;
    for (std::size_t i = 0; i < drives_; ++i) {
      const ServoDrive& d = drives[i];
      const ServoAmplifier& amp = *d.amplifier;
      Constants& c = c_[i];
      c.enabled = amp.enabled(d.enaOn);
      c.velocity = amp.parameters().mode == AmplifierMode::Velocity;
      c.peak = amp.parameters().peakTorque;
      const double command = c.enabled ? amp.command(d.volts) : 0.0;
      c.command = command;
      if (c.velocity) {
        c.omega = kTwoPi * command;
        const auto [kp, ki] = amp.gains(d.inertia);
        c.kp = kp;
        c.ki = ki;
      } else {
        c.torque = command;
      }
    }
  }

  [[nodiscard]] std::size_t dimension() const { return 2 + drives_; }
  // The hard stops in motor revolutions: every comparison with them, and
  // every stop the axis is put at, uses these same two numbers.
  [[nodiscard]] double hiRevs() const { return hiRevs_; }
  [[nodiscard]] double loRevs() const { return loRevs_; }
  [[nodiscard]] std::size_t drives() const { return drives_; }

  // The piece the state is in; clamps what the piece pins (a disabled
  // drive's integrator, one at its limit, a held axis' speed, the axis at a
  // hard stop).
  Piece classify(FlowVector& x) const {
    Piece piece;
    for (std::size_t i = 0; i < drives_; ++i) {
      const Constants& c = c_[i];
      double& integral = x[kIntegral + i];
      if (!c.enabled) {
        piece.drive[i] = DriveState::Off;
        integral = 0.0;  // a drive clears its loop when its enable drops
        continue;
      }
      if (!c.velocity) {
        piece.drive[i] = DriveState::Torque;
        continue;
      }
      const double error = c.omega - x[kSpeed];
      if (integral >= c.peak && error > 0) {
        piece.integrator[i] = Integrator::AtUpper;
        integral = c.peak;
      } else if (integral <= -c.peak && error < 0) {
        piece.integrator[i] = Integrator::AtLower;
        integral = -c.peak;
      } else {
        integral = std::clamp(integral, -c.peak, c.peak);
      }
      const double u = c.kp * error + integral;
      piece.drive[i] = u > c.peak ? DriveState::SaturatedUp : u < -c.peak ? DriveState::SaturatedDown : DriveState::Linear;
    }
    if (jammed_) {
      x[kSpeed] = 0.0;
      piece.motion = Motion::Held;
      return piece;
    }
    // Against a hard stop the axis stops dead.
    if ((x[kRevs] >= hiRevs_ && x[kSpeed] >= 0) || (x[kRevs] <= loRevs_ && x[kSpeed] <= 0)) {
      x[kRevs] = std::clamp(x[kRevs], loRevs_, hiRevs_);
      x[kSpeed] = 0.0;
    }
    if (x[kSpeed] > 0) {
      piece.motion = Motion::Forward;
    } else if (x[kSpeed] < 0) {
      piece.motion = Motion::Backward;
    } else {
      // At rest: it breaks away once the torques exceed what friction and
      // the brake hold, never into a hard stop it is against.
      const double applied = restingTorque(piece, x);
      if (applied > holding_ && x[kRevs] < hiRevs_)
        piece.motion = Motion::Forward;
      else if (applied < -holding_ && x[kRevs] > loRevs_)
        piece.motion = Motion::Backward;
      else
        piece.motion = Motion::Held;
    }
    // A drive's saturation was judged at the speed before a hard stop or
    // friction stopped the axis: judge it at rest.
    return piece.motion == Motion::Held ? reclassifyDrives(piece, x) : piece;
  }

  // x' = A x + c in `piece`: c always, A when asked for (a kept flow
  // needs only c).
  void system(const Piece& piece, FlowMatrix* a, FlowVector& c) const {
    if (a == nullptr) {
      input(piece, c);
      return;
    }
    FlowMatrix& m = *a;
    m = {};
    c = {};
    const double perJ = perInertia_;
    if (piece.motion != Motion::Held) {
      if (a != nullptr) {
        m[kRevs][kSpeed] = kRevsPerRadian;
        m[kSpeed][kSpeed] = -p_.viscous * perJ;
      }
      c[kSpeed] = (-p_.gravityTorque - (piece.motion == Motion::Forward ? holding_ : -holding_)) * perJ;
    }
    for (std::size_t i = 0; i < drives_; ++i) {
      const Constants& k = c_[i];
      const std::size_t ii = kIntegral + i;
      if (piece.motion != Motion::Held) {
        switch (piece.drive[i]) {
          case DriveState::Off: break;
          case DriveState::Torque: c[kSpeed] += k.torque * perJ; break;
          case DriveState::Linear:
            if (a != nullptr) {
              m[kSpeed][kSpeed] -= k.kp * perJ;
              m[kSpeed][ii] = perJ;
            }
            c[kSpeed] += k.kp * k.omega * perJ;
            break;
          case DriveState::SaturatedUp: c[kSpeed] += k.peak * perJ; break;
          case DriveState::SaturatedDown: c[kSpeed] -= k.peak * perJ; break;
        }
      }
      if (k.enabled && k.velocity && piece.integrator[i] == Integrator::Free) {
        if (a != nullptr) m[ii][kSpeed] = -k.ki;
        c[ii] = k.ki * k.omega;
      }
    }
  }

  // c alone (a kept flow needs nothing else): the same as system()'s.
  void input(const Piece& piece, FlowVector& c) const {
    const double perJ = perInertia_;
    double speed = 0.0;
    if (piece.motion != Motion::Held) {
      speed = -p_.gravityTorque - (piece.motion == Motion::Forward ? holding_ : -holding_);
      for (std::size_t i = 0; i < drives_; ++i) {
        const Constants& k = c_[i];
        switch (piece.drive[i]) {
          case DriveState::Off: break;
          case DriveState::Torque: speed += k.torque; break;
          case DriveState::Linear: speed += k.kp * k.omega; break;
          case DriveState::SaturatedUp: speed += k.peak; break;
          case DriveState::SaturatedDown: speed -= k.peak; break;
        }
      }
    }
    c[kRevs] = 0.0;
    c[kSpeed] = speed * perJ;
    for (std::size_t i = 0; i < drives_; ++i) {
      const Constants& k = c_[i];
      c[kIntegral + i] = k.enabled && k.velocity && piece.integrator[i] == Integrator::Free ? k.ki * k.omega : 0.0;
    }
  }

  // The guards of `piece` at state x: each an affine function of the
  // state that is >= 0 while the piece holds, of which this is the lowest
  // (so an event is where it goes negative). `start` is the state the
  // piece was chosen at: a held axis against a hard stop cannot break
  // away into it.
  [[nodiscard]] double margin(const Piece& piece, const FlowVector& start, const FlowVector& x) const {
    double m = std::numeric_limits<double>::infinity();
    if (piece.motion == Motion::Forward) {
      m = std::min(x[kSpeed], hiRevs_ - x[kRevs]);  // not yet at rest, short of the stop ahead
    } else if (piece.motion == Motion::Backward) {
      m = std::min(-x[kSpeed], x[kRevs] - loRevs_);
    } else if (!jammed_) {
      // Held: |applied| <= holding, applied = the drives' torques at rest
      // less gravity.
      const double applied = restingTorque(piece, x);
      if (start[kRevs] < hiRevs_) m = holding_ - applied;
      if (start[kRevs] > loRevs_) m = std::min(m, holding_ + applied);
    }
    for (std::size_t i = 0; i < drives_; ++i) {
      const Constants& k = c_[i];
      if (!k.enabled || !k.velocity) continue;
      const double integral = x[kIntegral + i];
      const double u = k.kp * (k.omega - x[kSpeed]) + integral;  // the loop's output before its limit
      switch (piece.drive[i]) {
        case DriveState::Linear: m = std::min(m, k.peak - std::abs(u)); break;
        case DriveState::SaturatedUp: m = std::min(m, u - k.peak); break;
        default: m = std::min(m, -u - k.peak); break;
      }
      switch (piece.integrator[i]) {
        case Integrator::Free: m = std::min(m, k.peak - std::abs(integral)); break;
        case Integrator::AtUpper: m = std::min(m, k.omega - x[kSpeed]); break;  // the error still drives it up
        case Integrator::AtLower: m = std::min(m, x[kSpeed] - k.omega); break;
      }
    }
    return m;
  }

  // What the event that ended `piece` at x (past it) does: a moving axis
  // come to rest, or at its hard stop; anything else only changes the piece.
  [[nodiscard]] GuardEvent event(const Piece& piece, const FlowVector& x) const {
    if (piece.motion == Motion::Forward) {
      if (x[kRevs] >= hiRevs_) return GuardEvent::HardStop;
      if (x[kSpeed] < 0.0) return GuardEvent::Rest;
    } else if (piece.motion == Motion::Backward) {
      if (x[kRevs] <= loRevs_) return GuardEvent::HardStop;
      if (x[kSpeed] > 0.0) return GuardEvent::Rest;
    }
    return GuardEvent::Switch;
  }

  // The velocity command of drive i (rev/s): 0 while disabled or in torque mode.
  [[nodiscard]] double velocityCommand(std::size_t i) const { return c_[i].velocity ? c_[i].command : 0.0; }

  // The drives' torques in the state (for the machine's state and trace).
  [[nodiscard]] double driveTorque(std::size_t i, const FlowVector& x) const {
    const Constants& k = c_[i];
    if (!k.enabled) return 0.0;
    if (!k.velocity) return k.torque;
    return std::clamp(k.kp * (k.omega - x[kSpeed]) + x[kIntegral + i], -k.peak, k.peak);
  }

  // A push moves the axis whatever the torques: the velocity loops see
  // its speed (rad/s) and integrate their error.
  void integrateAgainst(double speed, double seconds, FlowVector& x) const {
    for (std::size_t i = 0; i < drives_; ++i) {
      const Constants& k = c_[i];
      double& integral = x[kIntegral + i];
      if (!k.enabled) integral = 0.0;
      else if (k.velocity) integral = std::clamp(integral + k.ki * (k.omega - speed) * seconds, -k.peak, k.peak);
    }
  }

 private:
  struct Constants {
    bool enabled = false;
    bool velocity = false;
    double command = 0.0;  // what the drive makes of its input (0 while disabled)
    double peak = 0.0;
    double omega = 0.0;  // velocity mode: the command, rad/s
    double kp = 0.0, ki = 0.0;
    double torque = 0.0;  // torque mode: the command, Nm
  };

  [[nodiscard]] double restingTorque(const Piece& piece, const FlowVector& x) const {
    double applied = -p_.gravityTorque;
    FlowVector rest = x;
    rest[kSpeed] = 0.0;
    for (std::size_t i = 0; i < drives_; ++i)
      if (piece.drive[i] != DriveState::Off) applied += driveTorque(i, rest);
    return applied;
  }

  [[nodiscard]] Piece reclassifyDrives(Piece piece, const FlowVector& x) const {
    for (std::size_t i = 0; i < drives_; ++i) {
      const Constants& c = c_[i];
      if (!c.enabled || !c.velocity) continue;
      const double u = c.kp * (c.omega - x[kSpeed]) + x[kIntegral + i];
      piece.drive[i] = u > c.peak ? DriveState::SaturatedUp : u < -c.peak ? DriveState::SaturatedDown : DriveState::Linear;
      const double error = c.omega - x[kSpeed];
      if (piece.integrator[i] == Integrator::AtUpper && !(error > 0)) piece.integrator[i] = Integrator::Free;
      if (piece.integrator[i] == Integrator::AtLower && !(error < 0)) piece.integrator[i] = Integrator::Free;
    }
    return piece;
  }

  const AxisParameters& p_;
  std::size_t drives_;
  bool jammed_;
  double holding_ = 0.0;
  double hiRevs_ = 0.0, loRevs_ = 0.0;
  double perInertia_ = 0.0;
  std::array<Constants, kMaxDrivesPerAxis> c_{};
};


}  // namespace

const AffineFlow* ServoMotion::cached(std::uint64_t key, SimTime span) const {
  for (const Cached& c : cache_)
    if (c.key == key && c.span == span) return &c.flow;
  return nullptr;
}

void ServoMotion::keep(std::uint64_t key, SimTime span, const AffineFlow& flow) {
  Cached& slot = cache_[nextSlot_];
  nextSlot_ = (nextSlot_ + 1) % cache_.size();
  slot.key = key;
  slot.span = span;
  slot.flow = flow;
}

bool ServoMotion::restsUnpowered(const Axis& axis, bool brakeEngaged) {
  // At rest, not pushed, and friction and the brake holding what gravity
  // pulls (or jammed): with every drive off, the piece would be Held with
  // no guard that can move, all span.
  const AxisParameters& p = axis.p_;
  if (axis.speed_ != 0.0 || axis.pushLeft_ != 0.0) return false;
  return axis.jammed_ || std::abs(p.gravityTorque) <= p.coulomb + (brakeEngaged ? p.brakeTorque : 0.0);
}

bool ServoMotion::driveOff(const ServoAmplifier& amplifier, bool enaOn) {
  // Disabled with its loop cleared: no torque, no integral, no command
  // (what a span with it disabled leaves).
  return !amplifier.enabled(enaOn) && amplifier.integral_ == 0.0 && amplifier.velocityCommand_ == 0.0;
}

namespace {
bool drivesOff(std::span<const ServoDrive> drives) {
  for (const ServoDrive& d : drives)
    if (!ServoMotion::driveOff(*d.amplifier, d.enaOn)) return false;
  return true;
}
}  // namespace

void ServoMotion::advance(Axis& axis, std::span<ServoDrive> drives, bool brakeEngaged, SimTime span) {
  const double seconds = std::chrono::duration<double>(span).count();
  if (drives.size() > kMaxDrivesPerAxis) drives = drives.first(kMaxDrivesPerAxis);  // the machine refuses more
  if (span <= SimTime{0}) return;
  if (atRestChecked_ && restsUnpowered(axis, brakeEngaged) && drivesOff(drives)) {
    // Nothing to solve: it stays where it is (an idle machine, its drives
    // off since the host stopped, costs this check a span). The first such
    // span is solved, so that the axis' state (at a hard stop or not) is
    // the solution's.
    for (ServoDrive& d : drives) d.torque = 0.0;
    return;
  }
  const Problem problem(axis, drives, brakeEngaged);
  const std::size_t n = problem.dimension();
  FlowVector x{};
  x[kRevs] = axis.revs_;
  x[kSpeed] = kTwoPi * axis.speed_;
  for (std::size_t i = 0; i < drives.size(); ++i) x[kIntegral + i] = drives[i].amplifier->integral_;

  auto finish = [&] {
    // However the span ended (past its last watched event too), the axis
    // is within its hard stops, stopped dead at one.
    if ((x[kRevs] >= problem.hiRevs() && x[kSpeed] >= 0.0) || (x[kRevs] <= problem.loRevs() && x[kSpeed] <= 0.0)) {
      x[kRevs] = std::clamp(x[kRevs], problem.loRevs(), problem.hiRevs());
      x[kSpeed] = 0.0;
    }
    axis.revs_ = x[kRevs];
    axis.speed_ = x[kSpeed] * kRevsPerRadian;
    axis.stopped_ = (x[kRevs] >= problem.hiRevs() || x[kRevs] <= problem.loRevs()) && x[kSpeed] == 0.0;
    atRestChecked_ = restsUnpowered(axis, brakeEngaged) && drivesOff(drives);
    for (std::size_t i = 0; i < drives.size(); ++i) {
      ServoAmplifier& amp = *drives[i].amplifier;
      amp.integral_ = x[kIntegral + i];
      drives[i].torque = problem.driveTorque(i, x);
      amp.velocityCommand_ = problem.velocityCommand(i);
    }
  };

  if (axis.jammed_ == false && axis.pushLeft_ != 0.0) {
    // Kinematic: the outside force wins over the motors, friction and the
    // brake, at its own speed until it has moved its distance or the axis
    // meets a hard stop; then it lets go, the axis at rest.
    const double move = std::copysign(std::min(std::abs(axis.pushLeft_), axis.pushSpeed_ * seconds), axis.pushLeft_);
    const double revsPerUnit = 1.0 / axis.p_.unitsPerMotorRev;
    const double speed = move / seconds * revsPerUnit * kTwoPi;
    problem.integrateAgainst(speed, seconds, x);
    axis.pushLeft_ = std::abs(axis.pushLeft_) <= std::abs(move) ? 0.0 : axis.pushLeft_ - move;
    x[kRevs] += move * revsPerUnit;
    x[kSpeed] = axis.pushLeft_ != 0.0 ? speed : 0.0;
    if (x[kRevs] <= problem.loRevs() || x[kRevs] >= problem.hiRevs()) {
      x[kRevs] = std::clamp(x[kRevs], problem.loRevs(), problem.hiRevs());
      x[kSpeed] = 0.0;
      axis.pushLeft_ = 0.0;
    }
    finish();
    return;
  }

  FlowMatrix a;
  FlowVector c;
  double left = seconds;
  Piece piece = problem.classify(x);
  for (int found = 0; left > 0.0; ++found) {
    // The flow over the plant's usual span is kept per piece: a span
    // then costs one product. A span of another length, or what is left
    // of one after an event, is solved on the vector alone.
    const std::uint64_t key = piece.key(drives.size());
    const AffineFlow* whole = found == 0 ? cached(key, span) : nullptr;
    problem.system(piece, whole != nullptr ? nullptr : &a, c);
    if (whole == nullptr && found == 0 && span == lastSpan_) {
      keep(key, span, AffineFlow::over(a, n, seconds));
      ++flowsComputed_;
      whole = cached(key, span);
    }
    lastSpan_ = span;
    // The matrix is needed again only for an event's search.
    const bool haveMatrix = whole == nullptr;
    FlowVector end;
    if (whole != nullptr) {
      end = whole->apply(x, c);
    } else {
      end = AffineFlow::solve(a, n, x, c, left);
      ++solved_;
    }
    // After the most events a span may have, the rest of it is solved in
    // the last piece.
    const bool watching = found < kMaxEventsPerSpan;
    const FlowVector start = x;
    const double atEnd = watching ? problem.margin(piece, start, end) : 0.0;
    if (atEnd >= 0.0) {
      x = end;
      break;
    }
    // An event within the span: regula falsi (Illinois) on the lowest
    // guard, to the first time it is negative within the tolerance.
    ++events_;
    if (!haveMatrix) problem.system(piece, &a, c);
    double lo = 0.0, hi = left;
    double flo = std::max(0.0, problem.margin(piece, start, start)), fhi = atEnd;
    FlowVector xhi = end;
    int side = 0;
    for (int it = 0; it < 100 && hi - lo > kEventTolerance; ++it) {
      double t = (flo * hi - fhi * lo) / (flo - fhi);
      if (!(t > lo && t < hi)) t = 0.5 * (lo + hi);
      const FlowVector xt = AffineFlow::solve(a, n, x, c, t);
      ++solved_;
      const double ft = problem.margin(piece, start, xt);
      if (ft < 0.0) {
        hi = t;
        fhi = ft;
        xhi = xt;
        if (side == -1) flo *= 0.5;
        side = -1;
      } else {
        lo = t;
        flo = ft;
        if (side == 1) fhi *= 0.5;
        side = 1;
      }
    }
    const GuardEvent event = problem.event(piece, xhi);
    x = xhi;
    left -= hi;
    if (event == GuardEvent::Rest) x[kSpeed] = 0.0;  // friction stops it dead, not back through zero
    if (event == GuardEvent::HardStop) {
      x[kRevs] = piece.motion == Motion::Forward ? problem.hiRevs() : problem.loRevs();
      x[kSpeed] = 0.0;
    }
    piece = problem.classify(x);
  }
  finish();
}

}  // namespace lbpkit::model::machine
