// SPDX-License-Identifier: MIT
// SimClock, the one place `lbpkit sim` ties simulated time to a clock
// (docs/clocks.md), in a wall-clock time the test sets: the host clock's
// rules (one period per host cycle, the period learned from the first
// cycles, the wall clock again after a silence) hold exactly, on every run.
#include "daemon/sim_clock.hpp"

#include <gtest/gtest.h>

#include <chrono>

// The layers' namespaces this file names (docs/architecture.md).
namespace lbp = lbpkit::model::lbp;
namespace server = lbpkit::server;

namespace {

using namespace std::chrono_literals;
using lbp::SimTime;
using server::SimClock;

// The wall clock these tests read: set by hand.
SimClock::Wall::time_point wall{};
SimClock::Wall::time_point testWall() { return wall; }

class HostClockTest : public ::testing::Test {
 protected:
  void SetUp() override { wall = SimClock::Wall::time_point{} + 1h; }
  static void pass(std::chrono::nanoseconds d) { wall += d; }
};

TEST_F(HostClockTest, EachHostCycleMovesTimeOnePeriodWhateverTheWallClockDid) {
  SimClock c(server::HostClock{1ms, 20ms}, false, &testWall);
  EXPECT_EQ(c.source(), SimClock::Source::Host);
  EXPECT_EQ(c.period(), SimTime{1ms});
  c.hostCycle();
  const SimTime first = c.now();
  EXPECT_TRUE(c.drivenByHost());
  // Cycles 1 ms, 3.9 ms (a late period) and 0.1 ms (the catch-up) apart
  // each move time by the period, and time stands between them.
  for (const std::chrono::microseconds gap : {1000us, 3900us, 100us}) {
    const SimTime before = c.now();
    pass(gap / 2);
    EXPECT_EQ(c.now(), before) << "between cycles";
    pass(gap - gap / 2);
    c.hostCycle();
    EXPECT_EQ(c.now(), before + 1ms);
  }
  EXPECT_EQ(c.now(), first + 3ms);
  EXPECT_EQ(c.hostCycles(), 4U);
  EXPECT_EQ(c.silences(), 0U);
  // Every datagram of a cycle belongs to it: no wall-clock moment before.
  EXPECT_EQ(c.ago(500us), c.now());
}

TEST_F(HostClockTest, ASilentHostHandsTimeBackToTheWallClockFromItsLastCycle) {
  SimClock c(server::HostClock{1ms, 20ms}, false, &testWall);
  c.hostCycle();
  const SimTime atCycle = c.now();  // one period after the cycle
  pass(20ms);
  EXPECT_EQ(c.now(), atCycle) << "at the bound, still the host's";
  EXPECT_TRUE(c.drivenByHost());
  pass(1ms);
  // 21 ms of wall clock since the last cycle: the 7I77's 50 ms watchdog
  // counts them, as it would on the wall clock.
  EXPECT_FALSE(c.drivenByHost());
  EXPECT_EQ(c.now(), atCycle + 21ms);
  pass(29ms);
  EXPECT_EQ(c.now(), atCycle + 50ms);
  // The host comes back: a period on from where the wall clock took time.
  c.hostCycle();
  EXPECT_EQ(c.now(), atCycle + 51ms);
  EXPECT_TRUE(c.drivenByHost());
  EXPECT_EQ(c.silences(), 1U);
}

// The CPU taken from host and card together for 60 ms (the hypervisor, a
// real-time task): the card, woken 55 ms after its timer, counts that as
// its own absence, not the host's silence, and the host's next cycle is one
// period on. A host silent before the card was held back stays silent.
TEST_F(HostClockTest, TimeTheCardWasHeldBackIsNoSilenceOfTheHost) {
  SimClock c(server::HostClock{1ms, 40ms}, false, &testWall);
  c.hostCycle();
  const SimTime atCycle = c.now();
  pass(61ms);
  c.heldBack(55ms);  // its 5 ms timer, 55 ms late
  EXPECT_TRUE(c.drivenByHost());
  EXPECT_EQ(c.now(), atCycle);
  c.hostCycle();
  EXPECT_EQ(c.now(), atCycle + 1ms);
  EXPECT_EQ(c.silences(), 0U);
  EXPECT_EQ(c.heldBackFor(), 55ms);
  EXPECT_EQ(c.heldBackTimes(), 1U);
  // Under a millisecond is scheduling, not counted.
  c.heldBack(500us);
  EXPECT_EQ(c.heldBackTimes(), 1U);
  // Stopped 50 ms, the card held back for the last 5: the host was silent
  // beyond the bound (45 ms) when the card should have run, and stays so.
  const SimTime last = c.now();
  pass(50ms);
  c.heldBack(5ms);
  EXPECT_FALSE(c.drivenByHost());
  EXPECT_EQ(c.now(), last + 50ms);
  EXPECT_EQ(c.heldBackTimes(), 1U);
  // And the wall clock's run during a real silence starts later by as long
  // as the card was held back before it.
  c.hostCycle();
  const SimTime back = c.now();
  pass(30ms);
  c.heldBack(20ms);
  pass(25ms);  // 55 ms since the cycle, 35 of them the host's: not yet silent
  EXPECT_TRUE(c.drivenByHost());
  pass(10ms);  // 45 of them the host's
  EXPECT_FALSE(c.drivenByHost());
  EXPECT_EQ(c.now(), back + 45ms);
}

// A servo thread without real-time scheduling, kept 300 ms from its CPU:
// seen runnable every 5 ms, it is late, not stopped, and its next cycle is
// one period on, as on an on-time machine. A second after its last cycle a
// host still seen runnable is silent all the same, from that cycle.
TEST_F(HostClockTest, AHostSeenRunnableIsLateNotSilentForUpToASecond) {
  SimClock c(server::HostClock{1ms, 40ms}, false, &testWall);
  c.hostCycle();
  const SimTime atCycle = c.now();
  for (int i = 0; i < 60; ++i) {
    pass(5ms);
    c.hostRunning(wall);
  }
  EXPECT_TRUE(c.drivenByHost());
  EXPECT_EQ(c.now(), atCycle);
  c.hostCycle();
  EXPECT_EQ(c.now(), atCycle + 1ms);
  EXPECT_EQ(c.silences(), 0U);
  EXPECT_EQ(c.runningHolds(), 1U);
  const SimTime last = c.now();
  for (int i = 0; i < 200; ++i) {
    pass(5ms);
    c.hostRunning(wall);
  }
  pass(40ms);
  EXPECT_TRUE(c.drivenByHost()) << "seen runnable 1 s after its cycle: 40 ms more";
  pass(1ms);
  EXPECT_FALSE(c.drivenByHost());
  EXPECT_EQ(c.now(), last + 1041ms);
  c.hostCycle();
  EXPECT_EQ(c.silences(), 1U);
  EXPECT_EQ(c.runningHolds(), 1U);
}

// A host never seen runnable (stopped, killed, or asleep by its own
// choice) is silent at the bound; one seen runnable only after that does
// not take time back; and a host whose requests the network lost is silent
// at the bound however it runs (the card heard nothing of it).
TEST_F(HostClockTest, AHostSeenRunnableTooLateOrUnheardIsSilentAtTheBound) {
  SimClock c(server::HostClock{1ms, 40ms}, false, &testWall);
  c.hostCycle();
  const SimTime atCycle = c.now();
  pass(41ms);
  c.hostRunning(wall);
  EXPECT_FALSE(c.drivenByHost());
  EXPECT_EQ(c.now(), atCycle + 41ms);
  c.hostCycle();
  EXPECT_EQ(c.silences(), 1U);
  const SimTime back = c.now();
  pass(20ms);
  c.hostUnheard();
  c.hostRunning(wall);
  pass(21ms);
  c.hostRunning(wall);
  EXPECT_FALSE(c.drivenByHost());
  EXPECT_EQ(c.now(), back + 41ms);
  // The next cycle hears the host again: a sighting holds once more.
  c.hostCycle();
  const SimTime again = c.now();
  pass(30ms);
  c.hostRunning(wall);
  pass(30ms);
  EXPECT_TRUE(c.drivenByHost());
  EXPECT_EQ(c.now(), again);
  EXPECT_EQ(c.runningHolds(), 0U);
}

TEST_F(HostClockTest, ADoItTakenLateIsTakenAtWhenItCame) {
  // The card thread got to a DoIt 24 ms after it came, 1 ms after the last
  // cycle (the kernel held the sim back): the host was on time, and the
  // cycle is the host's, one period on.
  SimClock c(server::HostClock{1ms, 20ms}, false, &testWall);
  c.hostCycle();
  const SimTime t = c.now();
  pass(25ms);
  EXPECT_EQ(c.ago(24ms), t) << "the datagram that came 1 ms after the cycle";
  c.hostCycle(24ms);
  EXPECT_EQ(c.ago(24ms), t + 1ms);
  EXPECT_EQ(c.silences(), 0U);
  EXPECT_EQ(c.hostCycles(), 2U);
}

TEST_F(HostClockTest, BeforeTheFirstCycleTimeFollowsTheWallClock) {
  // hm2_eth's and setsserial's set-up come before any cycle: their
  // smart-serial commands need time to pass.
  SimClock c(server::HostClock{1ms, 20ms}, false, &testWall);
  EXPECT_EQ(c.now(), SimTime{0});
  pass(5ms);
  EXPECT_EQ(c.now(), SimTime{0}) << "within the bound of the start";
  pass(20ms);
  EXPECT_EQ(c.now(), SimTime{25ms});
  EXPECT_FALSE(c.drivenByHost());
}

// hostmot2 writes a STOP ALL after the DoIts of its discovery and gives it
// 51 ms of the wall clock (LinuxCNC: hostmot2/sserial.c): a host out of its
// cycle meets the wall clock from its last cycle on, at once, not after the
// silence, and its next cycle drives time again.
TEST_F(HostClockTest, AHostOutOfItsCycleMeetsTheWallClockUntilItsNextCycle) {
  SimClock c(server::HostClock{1ms, 40ms}, false, &testWall);
  c.hostCycle();
  const SimTime atCycle = c.now();
  pass(2ms);
  EXPECT_EQ(c.now(), atCycle) << "between cycles, time stands";
  c.hostLeftItsCycle();
  EXPECT_FALSE(c.drivenByHost());
  EXPECT_EQ(c.now(), atCycle + 2ms) << "the wall clock, from the last cycle";
  pass(100us);
  EXPECT_EQ(c.now(), atCycle + 2100us);
  c.hostLeftItsCycle();  // a second command: still out of the cycle, counted once
  EXPECT_EQ(c.cyclesLeft(), 1U);
  c.hostCycle();
  EXPECT_TRUE(c.drivenByHost());
  EXPECT_EQ(c.now(), atCycle + 2100us + 1ms);
  EXPECT_EQ(c.silences(), 0U) << "leaving the cycle is no silence";
  pass(30ms);
  EXPECT_EQ(c.now(), atCycle + 2100us + 1ms) << "driven again: time stands between cycles";
  // On the wall clock a command changes nothing.
  SimClock wallClock(1.0, false, &testWall);
  wallClock.hostLeftItsCycle();
  EXPECT_EQ(wallClock.cyclesLeft(), 0U);
}

TEST_F(HostClockTest, ThePeriodIsLearnedFromTheFirstCyclesSpacing) {
  SimClock c(server::HostClock{SimTime{0}, 20ms}, false, &testWall);
  c.hostCycle();  // the first: its spacing from set-up says nothing
  // 32 spacings near 1 ms, seven of them late or catching up (under a
  // fourth off by more than a fifth): the median, rounded to 10 us.
  for (std::size_t i = 0; i < SimClock::kLearnCycles; ++i) {
    EXPECT_EQ(c.period(), SimTime{0}) << "cycle " << i;
    pass(i % 8 == 7 ? 3900us : i % 8 == 0 && i > 0 ? 150us : 1003us);
    c.hostCycle();
  }
  EXPECT_EQ(c.period(), SimTime{1ms});
  const SimTime t = c.now();
  pass(4ms);
  c.hostCycle();
  EXPECT_EQ(c.now(), t + 1ms);
}

TEST_F(HostClockTest, SpacingsThatAreNoServoPeriodTeachNothing) {
  // Half the cycles 1 ms apart, half 5 ms: no period; nor 50 us, nor 20 ms.
  SimClock c(server::HostClock{SimTime{0}, 100ms}, false, &testWall);
  c.hostCycle();
  for (std::size_t i = 0; i < SimClock::kLearnCycles; ++i) {
    pass(i % 2 ? 1ms : 5ms);
    c.hostCycle();
  }
  EXPECT_EQ(c.period(), SimTime{0});
  for (const std::chrono::microseconds spacing : {50us, 20000us}) {
    for (std::size_t i = 0; i < SimClock::kLearnCycles; ++i) {
      pass(spacing);
      c.hostCycle();
    }
    EXPECT_EQ(c.period(), SimTime{0}) << spacing.count() << " us";
  }
  // Then 32 at 2 ms: learned.
  for (std::size_t i = 0; i < SimClock::kLearnCycles; ++i) {
    pass(2ms);
    c.hostCycle();
  }
  EXPECT_EQ(c.period(), SimTime{2ms});
}

TEST_F(HostClockTest, PausedTimeStandsAndStepsByHand) {
  SimClock c(server::HostClock{1ms, 20ms}, true, &testWall);
  c.hostCycle();
  EXPECT_EQ(c.now(), SimTime{0}) << "a cycle while paused moves nothing";
  EXPECT_EQ(c.hostCycles(), 0U);
  c.advanceBy(7ms);
  pass(1s);
  EXPECT_EQ(c.now(), SimTime{7ms});
  c.set(1.0, false);
  c.hostCycle();
  EXPECT_EQ(c.now(), SimTime{8ms});
}

TEST(WallClock, FollowsTheWallClockAtItsSpeedAndIgnoresHostCycles) {
  wall = SimClock::Wall::time_point{} + 1h;
  SimClock c(2.0, false, &testWall);
  EXPECT_EQ(c.source(), SimClock::Source::Wall);
  wall += 10ms;
  EXPECT_EQ(c.now(), SimTime{20ms});
  c.hostCycle();
  EXPECT_EQ(c.now(), SimTime{20ms});
  EXPECT_EQ(c.hostCycles(), 0U);
  EXPECT_FALSE(c.drivenByHost());
  EXPECT_EQ(c.ago(4ms), SimTime{12ms});
}

// A model that only moves is looked at every so much simulated time: in
// that much wall time at the clock's speed, never more often than every
// millisecond, and no less often than the simulated span itself.
TEST(WallClock, AModelThatOnlyMovesIsLookedAtEverySoMuchSimulatedTime) {
  wall = SimClock::Wall::time_point{} + 1h;
  SimClock c(1.0, false, &testWall);
  EXPECT_EQ(c.wallFor(250ms), 250ms);
  c.set(100.0, false);
  EXPECT_EQ(c.wallFor(250ms), 2ms);  // 2.5 ms, to the millisecond below
  c.set(1000.0, false);
  EXPECT_EQ(c.wallFor(250ms), 1ms);
  c.set(0.25, false);
  EXPECT_EQ(c.wallFor(250ms), 250ms);
  c.set(100.0, true);
  EXPECT_EQ(c.wallFor(250ms), 250ms);
}

// The sim answers each datagram at the simulated time it arrived
// (SimDaemon::run): ago() maps a moment of the wall clock past to simulated
// time, at the clock's speed, and not at all while paused.
TEST(SimClock, AgoIsTheSimulatedTimeOfAWallClockMomentPast) {
  using namespace std::chrono_literals;
  server::SimClock paused(1.0, true);
  paused.advanceBy(5ms);
  EXPECT_EQ(paused.ago(3ms), paused.now());  // paused time does not move
  server::SimClock doubled(2.0, false);
  doubled.advanceBy(100ms);  // simulated time well past 0
  const auto now = doubled.now();
  const auto back = doubled.ago(10ms);
  // 10 ms of wall clock are 20 ms simulated at speed 2 (plus what passed
  // between the two calls, which only makes `back` later).
  EXPECT_GE(back, now - 20ms);
  EXPECT_LT(back, now - 19ms);
  EXPECT_EQ(doubled.ago(1h), lbp::SimTime{0});  // never before the start
}

}  // namespace
