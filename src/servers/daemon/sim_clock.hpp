// The clock of `lbpkit sim`: the one place it ties simulated time to the wall clock.
//
// The models run in simulated time only and never read a clock; `lbpkit sim`
// makes that time follow the wall clock (scaled by a speed, or paused and
// stepped by hand) so that the 7I77 and HostMot2 watchdogs bite when a host
// really stops. Used on the card thread only.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <utility>

#include "lbp/sim_time.hpp"

namespace net {

class SimClock {
 public:
  explicit SimClock(double speed = 1.0, bool paused = false);
  [[nodiscard]] lbp::SimTime now() const;
  // Changes speed or pauses from now on: time so far is kept, never jumps.
  void set(double speed, bool paused);
  [[nodiscard]] double speed() const { return speed_; }
  [[nodiscard]] bool paused() const { return paused_; }
  void advanceBy(lbp::SimTime t);  // while paused: step time by hand
  // The simulated time it was `wallAgo` of wall-clock time ago (now() while
  // paused: paused time does not move).
  [[nodiscard]] lbp::SimTime ago(std::chrono::nanoseconds wallAgo) const;

  // Brings a model from `from` towards now() by calling advance(t) with t at
  // most kSlice apart, for at most `budget` of wall time, and returns where
  // it got. The work one catch-up does is bounded whatever the models cost
  // per simulated second, so the card thread always gets back to its socket,
  // its jobs and its stop flag. When that is not enough while time runs,
  // simulated time falls behind: the clock is set back to where the model
  // got (never past it), and the slip is counted. While paused nothing is
  // behind: the rest of a step is caught up on the next call.
  static constexpr lbp::SimTime kSlice = std::chrono::milliseconds(1);
  static constexpr std::chrono::microseconds kBudget{2000};
  template <typename Advance>
  lbp::SimTime catchUp(lbp::SimTime from, Advance&& advance, std::chrono::microseconds budget = kBudget) {
    return catchUpTo(from, now(), std::forward<Advance>(advance), budget);
  }
  // The same towards `target`, a simulated time at most now().
  template <typename Advance>
  lbp::SimTime catchUpTo(lbp::SimTime from, lbp::SimTime target, Advance&& advance,
                         std::chrono::microseconds budget = kBudget) {
    const auto start = Wall::now();
    lbp::SimTime t = from;
    while (t < target) {
      t = std::min(target, t + kSlice);
      advance(t);
      if (Wall::now() - start > budget) break;
    }
    if (t < target && !paused_) fallBackTo(t);
    return t;
  }
  // How far simulated time has fallen behind the wall clock in all, and how
  // many times.
  [[nodiscard]] lbp::SimTime behind() const { return behind_; }
  [[nodiscard]] std::uint64_t slips() const { return slips_; }

 private:
  void fallBackTo(lbp::SimTime t);

  using Wall = std::chrono::steady_clock;
  Wall::time_point wallBase_;
  lbp::SimTime simBase_{0};
  double speed_;
  bool paused_;
  lbp::SimTime behind_{0};
  std::uint64_t slips_ = 0;
};

}  // namespace net
