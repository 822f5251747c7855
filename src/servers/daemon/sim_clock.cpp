// SPDX-License-Identifier: MIT
#include "daemon/sim_clock.hpp"

#include <algorithm>
#include <cstdint>

namespace lbpkit::server {

SimClock::SimClock(double speed, bool paused, WallNow wall)
    : wallNow_(wall), wallBase_(wallNow_()), speed_(speed), paused_(paused) {}

SimClock::SimClock(const HostClock& host, bool paused, WallNow wall)
    : wallNow_(wall),
      source_(Source::Host),
      wallBase_(wallNow_()),
      speed_(1.0),
      paused_(paused),
      period_(host.period),
      silence_(host.silence) {}

model::lbp::SimTime SimClock::now() const { return at(wallNow_()); }

model::lbp::SimTime SimClock::at(Wall::time_point wall) const {
  if (paused_) return simBase_;
  if (source_ == Source::Host && period_.count() > 0 && !silent(wall)) return simBase_;
  // Never before the base: a moment before it (a datagram that came before
  // the last change) is taken at the base.
  const auto elapsed = std::max(0.0, std::chrono::duration<double, std::nano>(wall - wallBase_).count());
  return simBase_ + model::lbp::SimTime{static_cast<std::int64_t>(elapsed * speed_)};
}

bool SimClock::drivenByHost() const {
  return source_ == Source::Host && !paused_ && period_.count() > 0 && !silent(wallNow_());
}

std::chrono::milliseconds SimClock::wallFor(std::chrono::milliseconds simulated) const {
  if (paused_ || !(speed_ > 1.0)) return simulated;
  return std::max(std::chrono::milliseconds(1),
                  std::chrono::milliseconds(static_cast<std::int64_t>(static_cast<double>(simulated.count()) / speed_)));
}

void SimClock::set(double speed, bool paused) {
  simBase_ = now();
  wallBase_ = wallNow_();
  if (source_ == Source::Wall) speed_ = speed;
  paused_ = paused;
}

void SimClock::hostCycle(std::chrono::nanoseconds wallAgo) {
  if (source_ != Source::Host || paused_) return;
  // When the DoIt came, not when the card thread got to it: a card thread
  // the kernel held back must not make a host on time look silent.
  const auto wall = std::max(wallBase_, wallNow_() - wallAgo);
  const model::lbp::SimTime t = at(wall);
  if (hostCycles_ > 0 && !leftCycle_) {
    if (silent(wall))
      ++silences_;
    else if (wall - wallBase_ > silence_)
      ++runningHolds_;
  }
  leftCycle_ = false;
  unheard_ = false;
  if (period_.count() == 0) learn(wall);
  lastCycleWall_ = wall;
  ++hostCycles_;
  // The cycle's DOIT was taken at t; the host's next cycle meets the card
  // one period later, the DOIT done and the plant moved under the outputs
  // it wrote, as on a real-time machine on time.
  simBase_ = t + period_;
  wallBase_ = wall;
}

void SimClock::hostLeftItsCycle() {
  if (source_ != Source::Host || paused_ || leftCycle_) return;
  leftCycle_ = true;
  ++cyclesLeft_;
}

void SimClock::hostRunning(Wall::time_point wall) {
  if (source_ != Source::Host || paused_ || period_.count() == 0 || hostCycles_ == 0 || unheard_ || silent(wall))
    return;
  runningSeen_ = std::max(runningSeen_, wall);
}

void SimClock::heldBack(std::chrono::nanoseconds late) {
  if (source_ != Source::Host || paused_ || period_.count() == 0 || hostCycles_ == 0 || late < kHeldBackFrom) return;
  // Silent already when the card should have run: the host had stopped.
  if (silent(wallNow_() - late)) return;
  // The host's last cycle is taken as that much later: the silence, and
  // the wall clock's run from it, start later by as long.
  wallBase_ += late;
  heldBackFor_ += late;
  ++heldBackTimes_;
}

void SimClock::learn(Wall::time_point wall) {
  // The spacing of the first cycles, taken after the host's first one
  // (hostmot2's set-up exchanges come before it, not at the servo rate):
  // the median of kLearnCycles spacings when at least three in four are
  // within a fifth of it and it is a servo period (100 us to 10 ms),
  // rounded to 10 us. Otherwise the window starts again.
  if (hostCycles_ == 0) return;
  spacings_[learned_++] = std::chrono::duration_cast<std::chrono::nanoseconds>(wall - lastCycleWall_).count();
  if (learned_ < spacings_.size()) return;
  learned_ = 0;
  auto sorted = spacings_;
  std::nth_element(sorted.begin(), sorted.begin() + kLearnCycles / 2, sorted.end());
  const std::int64_t median = sorted[kLearnCycles / 2];
  const auto near = std::count_if(spacings_.begin(), spacings_.end(),
                                  [median](std::int64_t s) { return s * 5 >= median * 4 && s * 5 <= median * 6; });
  if (median < 100'000 || median > 10'000'000 || static_cast<std::size_t>(near) * 4 < kLearnCycles * 3) return;
  period_ = model::lbp::SimTime{(median + 5'000) / 10'000 * 10'000};
}

void SimClock::fallBackTo(model::lbp::SimTime t) {
  const auto wall = wallNow_();
  const auto lag = now() - t;
  if (lag <= model::lbp::SimTime{0}) return;
  simBase_ = t;
  wallBase_ = wall;
  behind_ += lag;
  ++slips_;
}

model::lbp::SimTime SimClock::ago(std::chrono::nanoseconds wallAgo) const {
  if (source_ == Source::Host) return at(wallNow_() - wallAgo);
  const model::lbp::SimTime t = now();
  if (paused_) return t;
  const auto back = model::lbp::SimTime{static_cast<std::int64_t>(static_cast<double>(wallAgo.count()) * speed_)};
  // Across a change of speed this is approximate, which is harmless: the
  // card never runs back, so a time before its own is taken as its own.
  return std::max(model::lbp::SimTime{0}, t - back);
}

void SimClock::advanceBy(model::lbp::SimTime t) {
  simBase_ = now() + t;
  wallBase_ = wallNow_();
}

}  // namespace lbpkit::server
