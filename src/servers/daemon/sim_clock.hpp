// SPDX-License-Identifier: MIT
// The clock of `lbpkit sim`: the one place it ties simulated time to a clock.
//
// The models run in simulated time only and never read a clock; `lbpkit sim`
// makes that time follow one of two clocks (docs/clocks.md):
//
// - the wall clock (the default), scaled by a speed, or paused and stepped by
//   hand: what a real card lives in, so the 7I77 and HostMot2 watchdogs bite
//   when a host really stops, and a host that runs late sees a plant that
//   moved on meanwhile, as real hardware would;
// - the host's servo cycles (`--clock host[=PERIOD]`): simulated time moves
//   one servo period for each cycle the host completes (each smart-serial
//   DOIT it writes, which LinuxCNC's hostmot2 and lbpkit's host library both
//   write once a cycle), so a host whose servo thread runs late on a kernel
//   without real-time scheduling still meets the plant one period after its
//   last cycle, exactly as an on-time real-time machine would. A host silent
//   for longer than a bound well under the 7I77's 50 ms watchdog (and not
//   seen runnable meanwhile: host_watch.hpp) hands time back to the wall
//   clock from its last cycle on, so a killed host still trips every
//   watchdog on time.
//
// Used on the card thread only.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <utility>

#include "lbp/sim_time.hpp"

namespace lbpkit::server {

// `--clock host[=PERIOD]`.
struct HostClock {
  // One servo period of simulated time a host cycle; zero: learned from the
  // wall-clock spacing of the host's first cycles (SimClock::kLearnCycles).
  model::lbp::SimTime period{0};
  // A host silent this long (wall clock) has stopped: time follows the wall
  // clock again, counted from its last cycle, so the 7I77's 50 ms watchdog
  // still bites 50 ms after it (any bound under 50 ms less a period does
  // that). Over the longest late servo period seen from LinuxCNC without a
  // real-time kernel (27 ms on a 2-core virtual machine; docs/clocks.md).
  std::chrono::milliseconds silence{40};
};

class SimClock {
 public:
  enum class Source : std::uint8_t { Wall, Host };
  using Wall = std::chrono::steady_clock;
  // Where the clock reads the wall clock: steady_clock, or a test's own
  // (so the clock's rules are tested in a time the test sets).
  using WallNow = Wall::time_point (*)();
  explicit SimClock(double speed = 1.0, bool paused = false, WallNow wall = &Wall::now);
  SimClock(const HostClock& host, bool paused, WallNow wall = &Wall::now);
  [[nodiscard]] model::lbp::SimTime now() const;
  // Changes speed or pauses from now on: time so far is kept, never jumps.
  // On the host clock the speed stays 1 (what follows the wall clock).
  void set(double speed, bool paused);
  [[nodiscard]] double speed() const { return speed_; }
  [[nodiscard]] bool paused() const { return paused_; }
  // The wall time in which `simulated` passes at this speed, at least a
  // millisecond and never longer than `simulated` itself (slower than the
  // wall clock, or paused, a look that often is often enough): how long
  // the card thread may sleep between looks at a model that only moves.
  [[nodiscard]] std::chrono::milliseconds wallFor(std::chrono::milliseconds simulated) const;
  void advanceBy(model::lbp::SimTime t);  // while paused: step time by hand
  // The simulated time it was `wallAgo` of wall-clock time ago (now() while
  // paused; on the host clock, the time of the cycle a datagram came in, or
  // the wall clock's if the host was silent by then).
  [[nodiscard]] model::lbp::SimTime ago(std::chrono::nanoseconds wallAgo) const;

  // --- The host clock --------------------------------------------------------------
  [[nodiscard]] Source source() const { return source_; }
  // A host completed a servo cycle (its DOIT, which came `wallAgo` ago, was
  // taken): simulated time moves on by one period from then. Ignored on the
  // wall clock and while paused; before the period is known, each cycle's
  // wall-clock spacing is learned from and time follows the wall clock.
  void hostCycle(std::chrono::nanoseconds wallAgo = std::chrono::nanoseconds{0});
  // The period a host cycle moves time (zero while still being learned).
  [[nodiscard]] model::lbp::SimTime period() const { return period_; }
  [[nodiscard]] std::chrono::milliseconds silence() const { return silence_; }
  [[nodiscard]] std::uint64_t hostCycles() const { return hostCycles_; }
  // True when time follows a host's cycles right now; false on the wall
  // clock, while paused, while the period is learned and while the host
  // is silent beyond the bound.
  [[nodiscard]] bool drivenByHost() const;
  // How many times a host came back after a silence beyond the bound.
  [[nodiscard]] std::uint64_t silences() const { return silences_; }
  // The host wrote a smart-serial command that is not a DOIT (a STOP, a
  // START, a parameter access): it is setting the card up or recovering a
  // channel, out of its servo cycle, and waits for the firmware on the wall
  // clock (hostmot2 gives a STOP ALL 51 ms, a local read 22 ms, the STOP of
  // its channel recovery 26 ms: LinuxCNC hostmot2/sserial.c). Time follows
  // the wall clock from the host's last cycle on, as after a silence, until
  // its next cycle. Held at the cycle's time instead, such a command would
  // finish only when the host fell silent (40 ms): the STOP ALL hostmot2
  // writes after its discovery DOITs then had 11 ms to spare, and none at
  // all when the card was held back.
  void hostLeftItsCycle();
  // How many times a host left its cycle that way.
  [[nodiscard]] std::uint64_t cyclesLeft() const { return cyclesLeft_; }
  // The card thread ran `late` after it should have (it woke that long
  // after its timer, or took a datagram that long after it came): while a
  // host drives time, that much of a silence is the card's own, not the
  // host's. A host and a card on one CPU (as `lbpkit linuxcnc` and the
  // tests run them) stop together when the CPU is taken from both, by the
  // hypervisor or by a real-time task; a card that counted such a stall as
  // the host's silence took the host for stopped and let the 7I77's
  // watchdog bite, though the host was never late by its own doing. A host
  // silent before the card was held back stays silent; a stopped host's
  // silence is only counted later by as long as the card was held back.
  void heldBack(std::chrono::nanoseconds late);
  // The host's process was seen runnable at `wall` (process::threadsState:
  // a thread of it running or waiting for a CPU): a host that has not
  // cycled since is late, not stopped. A servo thread without real-time
  // scheduling waits for its CPU behind other work, 50 ms and more on a
  // busy PC; an on-time machine never does, and its 7I77 never sees the
  // gap. So while the host is seen runnable, its silence counts from the
  // sighting, for up to kRunningHostBound after its last cycle: a host
  // stopped (SIGSTOP), killed, or alive but no longer cycling is never
  // seen runnable, and is silent at the bound as ever. Ignored when the
  // host is silent already (time has run on: it is not taken back), and
  // after hostUnheard() until the next cycle.
  void hostRunning(Wall::time_point wall);
  // A datagram of the host's was lost on its way to the card (a network
  // fault: dropped, silenced, corrupted): the card hears nothing of the
  // host, however it runs, and its silence counts from its last cycle.
  void hostUnheard() { unheard_ = true; }
  // How long a host seen runnable may stay silent (docs/clocks.md): over
  // the longest wait for a CPU a servo thread meets on a loaded PC without
  // real-time scheduling, and short enough that a host which hangs while
  // runnable still meets its watchdogs, in simulated time as ever, a
  // second late on the wall clock.
  static constexpr std::chrono::milliseconds kRunningHostBound{1000};
  // How many times a host came back after a silence beyond the bound that
  // was held because it was seen runnable (for /api/state): each a time
  // a host without real-time scheduling would have been taken as stopped.
  [[nodiscard]] std::uint64_t runningHolds() const { return runningHolds_; }
  // How long a host-driven card has been held back in all, and how often
  // (for /api/state).
  [[nodiscard]] std::chrono::nanoseconds heldBackFor() const { return heldBackFor_; }
  [[nodiscard]] std::uint64_t heldBackTimes() const { return heldBackTimes_; }
  // A held-back card notices only when it wakes: while a host drives time,
  // the card thread waits at most this long, so that a stall of its CPU is
  // a timer missed (a host at its period wakes it sooner anyway).
  static constexpr std::chrono::milliseconds kHeldBackCheck{10};
  // Scheduling delays under this are not counted.
  static constexpr std::chrono::milliseconds kHeldBackFrom{1};

  // Brings a model from `from` towards now() by calling advance(t) with t at
  // most kSlice apart, for at most `budget` of wall time, and returns where
  // it got. The work one catch-up does is bounded whatever the models cost
  // per simulated second, so the card thread always gets back to its socket,
  // its jobs and its stop flag. When that is not enough while time runs on
  // the wall clock, simulated time falls behind: the clock is set back to
  // where the model got (never past it), and the slip is counted. While
  // paused, or driven by a host's cycles, nothing is behind: the rest is
  // caught up on the next call.
  static constexpr model::lbp::SimTime kSlice = std::chrono::milliseconds(1);
  // A card alone (no machine behind it) is event-driven: each part's
  // advance() is a comparison until something is due, and counting is
  // exact over any span, so it is caught up in long slices: after a
  // sleep of an hour, a few thousand comparisons.
  static constexpr model::lbp::SimTime kCardSlice = std::chrono::seconds(1);
  static constexpr std::chrono::microseconds kBudget{2000};
  // Driven by a host's cycles, each datagram is answered at the cycle's
  // time, whatever the wall clock did meanwhile: a period of simulation
  // costs microseconds, so this bound is never what stops a catch-up.
  static constexpr std::chrono::microseconds kHostBudget{1'000'000};
  // Cycles whose spacing a learned period is taken from.
  static constexpr std::size_t kLearnCycles = 32;
  template <typename Advance>
  model::lbp::SimTime catchUp(model::lbp::SimTime from, Advance&& advance, std::chrono::microseconds budget = kBudget) {
    return catchUpTo(from, now(), std::forward<Advance>(advance), budget);
  }
  // The same towards `target`, a simulated time at most now(), in slices
  // of at most `slice`.
  template <typename Advance>
  model::lbp::SimTime catchUpTo(model::lbp::SimTime from, model::lbp::SimTime target, Advance&& advance,
                                std::chrono::microseconds budget = kBudget, model::lbp::SimTime slice = kSlice) {
    const auto start = Wall::now();
    model::lbp::SimTime t = from;
    while (t < target) {
      t = std::min(target, t + slice);
      advance(t);
      if (Wall::now() - start > budget) break;
    }
    if (t < target && !paused_ && source_ == Source::Wall) fallBackTo(t);
    return t;
  }
  // How far simulated time has fallen behind the wall clock in all, and how
  // many times.
  [[nodiscard]] model::lbp::SimTime behind() const { return behind_; }
  [[nodiscard]] std::uint64_t slips() const { return slips_; }

 private:
  void fallBackTo(model::lbp::SimTime t);
  [[nodiscard]] model::lbp::SimTime at(Wall::time_point wall) const;  // simulated time at a wall-clock moment
  void learn(Wall::time_point wall);
  // The host's last sign of life: its last cycle, or a later sighting of
  // it runnable within kRunningHostBound of that.
  [[nodiscard]] Wall::time_point lastSign() const {
    return unheard_ ? wallBase_ : std::max(wallBase_, std::min(runningSeen_, wallBase_ + kRunningHostBound));
  }
  [[nodiscard]] bool silent(Wall::time_point wall) const { return leftCycle_ || wall - lastSign() > silence_; }

  WallNow wallNow_;
  Source source_ = Source::Wall;
  // Wall clock: simulated time is simBase_ + (wall - wallBase_) x speed.
  // Host clock: simBase_ is the time of the host's last cycle and wallBase_
  // when it came; silent beyond the bound (or learning), time runs on from
  // there with the wall clock.
  Wall::time_point wallBase_;
  model::lbp::SimTime simBase_{0};
  double speed_;
  bool paused_;
  model::lbp::SimTime behind_{0};
  std::uint64_t slips_ = 0;
  model::lbp::SimTime period_{0};
  std::chrono::milliseconds silence_{20};
  std::uint64_t hostCycles_ = 0;
  std::uint64_t silences_ = 0;
  bool leftCycle_ = false;  // hostLeftItsCycle() since the last cycle
  bool unheard_ = false;    // hostUnheard() since the last cycle
  Wall::time_point runningSeen_{};  // hostRunning()'s latest sighting
  std::uint64_t runningHolds_ = 0;
  std::uint64_t cyclesLeft_ = 0;
  std::chrono::nanoseconds heldBackFor_{0};
  std::uint64_t heldBackTimes_ = 0;
  Wall::time_point lastCycleWall_{};
  std::array<std::int64_t, kLearnCycles> spacings_{};  // ns, while the period is learned
  std::size_t learned_ = 0;
};

}  // namespace lbpkit::server
