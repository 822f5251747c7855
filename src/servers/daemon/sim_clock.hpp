// The clock of `lbpkit sim`: the one place it ties simulated time to the wall clock.
//
// The models run in simulated time only and never read a clock; `lbpkit sim`
// makes that time follow the wall clock (scaled by a speed, or paused and
// stepped by hand) so that the 7I77 and HostMot2 watchdogs bite when a host
// really stops. Used on the card thread only.
#pragma once

#include <chrono>

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

 private:
  using Wall = std::chrono::steady_clock;
  Wall::time_point wallBase_;
  lbp::SimTime simBase_{0};
  double speed_;
  bool paused_;
};

}  // namespace net
