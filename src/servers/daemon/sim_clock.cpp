#include "daemon/sim_clock.hpp"

#include <algorithm>
#include <cstdint>

namespace net {

SimClock::SimClock(double speed, bool paused) : wallBase_(Wall::now()), speed_(speed), paused_(paused) {}

lbp::SimTime SimClock::now() const {
  if (paused_) return simBase_;
  const auto wall = std::chrono::duration<double, std::nano>(Wall::now() - wallBase_).count();
  return simBase_ + lbp::SimTime{static_cast<std::int64_t>(wall * speed_)};
}

void SimClock::set(double speed, bool paused) {
  simBase_ = now();
  wallBase_ = Wall::now();
  speed_ = speed;
  paused_ = paused;
}

void SimClock::fallBackTo(lbp::SimTime t) {
  const auto wall = Wall::now();
  const auto lag = now() - t;
  if (lag <= lbp::SimTime{0}) return;
  simBase_ = t;
  wallBase_ = wall;
  behind_ += lag;
  ++slips_;
}

lbp::SimTime SimClock::ago(std::chrono::nanoseconds wallAgo) const {
  const lbp::SimTime t = now();
  if (paused_) return t;
  const auto back = lbp::SimTime{static_cast<std::int64_t>(static_cast<double>(wallAgo.count()) * speed_)};
  // Across a change of speed this is approximate, which is harmless: the
  // card never runs back, so a time before its own is taken as its own.
  return std::max(lbp::SimTime{0}, t - back);
}

void SimClock::advanceBy(lbp::SimTime t) {
  simBase_ = now() + t;
  wallBase_ = Wall::now();
}

}  // namespace net
