// SPDX-License-Identifier: MIT
// `lbpkit sim --clock host=PERIOD`: the clocks the CLI takes and refuses,
// and the card's time driven by lbpkit's own host library, a servo period
// for each of its cycles, the wall clock when it leaves its cycle or falls
// silent. Each test starts its own sim on a loopback address of its own.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "support/process.hpp"
#include "support/sim_api.hpp"
#include "support/sim_child.hpp"

namespace {

using namespace std::chrono_literals;
using namespace test_support::sim_api;
using nlohmann::json;

// `--clock`: what it takes, and what it refuses, naming the option.
TEST(SimApi, CliRefusesClocksItDoesNotKnow) {
  for (const auto& extra :
       {std::vector<std::string>{"--clock", "sun"}, {"--clock", "host=50us"}, {"--clock", "host=11ms"},
        {"--clock", "host=1s"}, {"--clock", "host=ms"}, {"--clock", "host=1ms", "--speed", "2"}}) {
    const auto state = tempPath("clock");
    std::vector<std::string> args = {"sim", "--bind", loopback(11) + ":0", "--api", "0", "--no-realtime", "--state",
                                     state};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto r = test_support::run(args, std::chrono::seconds(5));
    EXPECT_NE(r.exit, 0) << extra[1];
    EXPECT_NE(r.err.find("--clock"), std::string::npos) << extra[1] << ": " << r.err;
    test_support::removeStateFiles(state);
  }
}

// On the host clock, lbpkit's own host library drives time: each of its
// cycles (a DoIt) moves the card one period, however the cycles are spaced
// on the wall clock; the API shows the clock and refuses a speed. The
// period in nanoseconds, as [EMCMOT]SERVO_PERIOD gives it and `lbpkit
// linuxcnc` passes it on.
TEST(SimApi, OnTheHostClockEachHostCycleIsOnePeriod) {
  Sim sim(loopback(18), {"--clock", "host=1000000"});
  ASSERT_TRUE(sim.up());
  EXPECT_NE(sim.daemon().readUntil("per host cycle").find("one servo period (1 ms) per host cycle"), std::string::npos);
  HostOnSim host(sim);
  auto& t = host.t;
  auto& ss = host.ss;
  ASSERT_TRUE(ss.cycle().ok);
  const json before = sim.get().body;
  ASSERT_EQ(before["clock"]["source"], "host") << before["clock"];
  EXPECT_EQ(before["clock"]["period_ms"], 1.0);
  constexpr int kCycles = 300;
  for (int i = 0; i < kCycles; ++i) {
    ASSERT_TRUE(ss.cycle().ok) << i;
    if (i % 50 == 0) t.sleep(4ms);  // a late period: still one period
  }
  const json after = sim.get().body;
  EXPECT_EQ(after["clock"]["host_cycles"].get<std::uint64_t>() - before["clock"]["host_cycles"].get<std::uint64_t>(),
            static_cast<std::uint64_t>(kCycles));
  // A period a cycle, exactly; a cycle that came over 40 ms after the last
  // (this test's process held back on a busy machine: the sim cannot tell
  // that from a host that stopped) adds the wall-clock time it was silent.
  const auto silences =
      after["clock"]["host_silences"].get<std::uint64_t>() - before["clock"]["host_silences"].get<std::uint64_t>();
  // A look at the clock over 40 ms after the last cycle reads it moved on
  // with the wall clock too: exact only when both looks found the host
  // driving it.
  const double elapsed = after["time_s"].get<double>() - before["time_s"].get<double>();
  const bool driven = before["clock"]["driven_by_host"] == true && after["clock"]["driven_by_host"] == true;
  if (silences == 0 && driven)
    EXPECT_NEAR(elapsed, kCycles * 1e-3, 1e-9);
  else
    EXPECT_GT(elapsed, kCycles * 1e-3) << silences << " silences";
  const auto speed = sim.post("/api/time", {{"speed", 2}});
  EXPECT_EQ(speed.status, 400);
  EXPECT_NE(speed.body.value("error", "").find("host"), std::string::npos) << speed.body;
  // A silent host: time follows the wall clock again, and the 7I77's
  // watchdog bites (its outputs off) as on the wall clock.
  std::this_thread::sleep_for(120ms);
  const json silent = sim.get().body;
  EXPECT_EQ(silent["clock"]["driven_by_host"], false);
  EXPECT_GT(silent["time_s"].get<double>() - after["time_s"].get<double>(), 0.1);
  const auto& faults = silent["daughtercards"][0]["field_io"]["faults"];
  EXPECT_NE(std::find(faults.begin(), faults.end(), "WatchdogFault"), faults.end()) << silent["daughtercards"][0];
}

// hm2_eth's set-up writes a STOP ALL after its discovery DoIts and gives it
// 51 ms of the wall clock (LinuxCNC: hostmot2/sserial.c). A command that is
// no DoIt takes the host out of its cycle: the card follows the wall clock
// at once (the STOP done in its firmware time, not after the host's 40 ms
// silence), and the next cycle drives time again.
TEST(SimApi, OnTheHostClockACommandOutOfTheCycleMeetsTheWallClock) {
  Sim sim(loopback(18), {"--clock", "host=1ms"});
  ASSERT_TRUE(sim.up());
  HostOnSim host(sim);
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(host.ss.cycle().ok) << i;
  const json cycling = sim.get().body;
  // stopAll() writes STOP ALL and reads COMMAND until it clears.
  EXPECT_EQ(host.ss.stopAll(), 0xAA) << "DATA after the global init";
  const json stopped = sim.get().body;
  EXPECT_EQ(stopped["clock"]["driven_by_host"], false) << stopped["clock"];
  EXPECT_EQ(stopped["clock"]["host_left_cycle"].get<std::uint64_t>(),
            cycling["clock"]["host_left_cycle"].get<std::uint64_t>() + 1)
      << stopped["clock"];
  EXPECT_EQ(stopped["clock"]["host_silences"], cycling["clock"]["host_silences"]) << "no silence counted";
  EXPECT_GE(stopped["clock"]["host_cycles"].get<std::uint64_t>(), 20U);
}

}  // namespace
