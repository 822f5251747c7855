// SPDX-License-Identifier: MIT
// The host library's smart-serial error handling: a per-channel
// fault count with LinuxCNC's increment, decrement and limit, SSLBP's
// TooManyErrors reported per channel, and recovery (STOP of the channel and
// a normal START) by the caller or, with Options::autoRecover, by the cycle
// itself. In simulated time, over the in-process card, with the cable of one
// channel cut (hm2::SerialLink) so every one of its DOITs fails.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>

#include "lbpkit/wire/sslbp.hpp"
#include "support/running_card.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

namespace {

using namespace std::chrono_literals;
using testing_host::RunningCard;

constexpr unsigned kFieldIo = 0;
constexpr unsigned kAnalog = 1;
constexpr std::uint8_t kBit0 = 1U << kFieldIo;

lbpkit::CycleStatus cycle(RunningCard& rc) {
  const auto start = rc.t.now();
  const auto st = rc.ss.cycle();
  const auto spent = rc.t.now() - start;
  if (spent < 1ms) rc.t.sleep(1ms - spent);
  return st;
}

TEST(HostFaultLimit, DefaultsAreLinuxCncs) {
  const lbpkit::SmartSerial::Options o;
  EXPECT_EQ(o.faultIncrement, 10U);  // hostmot2 sserial: fault-inc
  EXPECT_EQ(o.faultDecrement, 1U);   // fault-dec
  EXPECT_EQ(o.faultLimit, 200U);     // fault-lim
  EXPECT_FALSE(o.autoRecover);
}

// Every DOIT of channel 0 fails: its count climbs by 10 - 1 a cycle and is
// over the limit 200 at the 23rd failure (207); SSLBP's own count sets
// TooManyErrors at the 21st timeout. Channel 1 is not touched. Nothing
// restarts by itself; once the cable is back the count decays by 1 a cycle,
// and recover() clears both.
TEST(HostFaultLimit, ACutCableClimbsToTheLimitAndRecoverClearsIt) {
  RunningCard rc;
  auto& link = rc.t.card().part<hm2::Sslbp>().link(kFieldIo);
  const auto input = rc.ss.find(kFieldIo, "input");
  auto& io = rc.t.card().daughtercard(0).fieldIo;
  io.setInputVoltage(7, 24.0);
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(cycle(rc).ok);
  ASSERT_EQ(rc.ss.raw(input) & 0xFF, 0x80U);
  EXPECT_EQ(rc.ss.faultCount(kFieldIo), 0U);

  link.setConnected(false);
  io.setInputVoltage(7, 0.0);
  unsigned firstTooMany = 0, firstOverLimit = 0;
  for (unsigned n = 1; n <= 30; ++n) {
    const auto st = cycle(rc);
    ASSERT_FALSE(st.ok);
    EXPECT_EQ(st.failedMask, kBit0) << n;
    EXPECT_EQ(st.freshMask, 1U << kAnalog) << n;
    EXPECT_EQ(st.recoveredMask, 0U);
    EXPECT_EQ(rc.ss.faultCount(kFieldIo), 9U * n) << n;
    EXPECT_EQ(rc.ss.faultCount(kAnalog), 0U) << n;
    EXPECT_EQ(rc.ss.raw(input) & 0xFF, 0x80U) << n;  // the last good inputs
    if (st.tooManyErrorsMask && !firstTooMany) firstTooMany = n;
    if (st.overLimitMask && !firstOverLimit) firstOverLimit = n;
    if (firstOverLimit) {
      EXPECT_EQ(st.overLimitMask, kBit0);
    }
    if (firstTooMany) {
      EXPECT_EQ(st.needsRecovery(), kBit0);
    }
  }
  EXPECT_EQ(firstTooMany, 21U);   // 20 errors of a kind are tolerated
  EXPECT_EQ(firstOverLimit, 23U);  // 9 x 23 = 207 > 200
  EXPECT_EQ(rc.ss.recoveries(kFieldIo), 0U);  // the caller's, by default

  // The cable back: DOITs succeed, the count decays, TooManyErrors stays.
  link.setConnected(true);
  auto st = cycle(rc);
  EXPECT_TRUE(st.freshMask & kBit0);
  EXPECT_EQ(rc.ss.faultCount(kFieldIo), 9U * 30 - 1);
  EXPECT_EQ(st.tooManyErrorsMask, kBit0);
  EXPECT_EQ(rc.ss.raw(input) & 0xFF, 0x00U);

  ASSERT_TRUE(rc.ss.recover(kFieldIo));
  EXPECT_TRUE(rc.ss.running(kFieldIo));
  EXPECT_EQ(rc.ss.faultCount(kFieldIo), 0U);
  EXPECT_EQ(rc.ss.recoveries(kFieldIo), 1U);
  EXPECT_EQ(rc.ss.cs(kFieldIo) & lbpkit::wire::sslbp::cs::kTooManyErrors, lbpkit::wire::sslbp::cs::kTooManyErrors)
      << "cs() is the last cycle's";
  st = cycle(rc);
  EXPECT_TRUE(st.ok);
  EXPECT_EQ(st.needsRecovery(), 0U);
  EXPECT_EQ(rc.ss.cs(kFieldIo) & 0xFF, 0U);  // START cleared SSLBP's error log
  EXPECT_FALSE(rc.ss.recover(kFieldIo));     // at most once per recoveryInterval
}

// Another increment, decrement and limit: 3 - 1 a failure, over 5 at the 3rd.
TEST(HostFaultLimit, TheRuleTakesTheCallersFigures) {
  lbpkit::SmartSerial::Options o = testing_host::channels(0x03);
  o.faultIncrement = 3;
  o.faultDecrement = 1;
  o.faultLimit = 5;
  lbpkit::SimTransport t;
  const auto info = lbpkit::readCardInfo(t);
  lbpkit::SmartSerial ss(t, info, o);
  ss.discover(0x03);
  ss.startNormal();
  auto& link = t.card().part<hm2::Sslbp>().link(kAnalog);
  ASSERT_TRUE(ss.cycle().ok);
  link.setConnected(false);
  EXPECT_EQ(ss.cycle().overLimitMask, 0U);
  EXPECT_EQ(ss.faultCount(kAnalog), 2U);
  EXPECT_EQ(ss.cycle().overLimitMask, 0U);
  EXPECT_EQ(ss.faultCount(kAnalog), 4U);
  EXPECT_EQ(ss.cycle().overLimitMask, 1U << kAnalog);
  EXPECT_EQ(ss.faultCount(kAnalog), 6U);
  link.setConnected(true);
  // Good cycles take it down by the decrement, not below 0.
  for (unsigned n = 1; n <= 8; ++n) {
    const auto st = ss.cycle();
    EXPECT_EQ(ss.faultCount(kAnalog), n < 6 ? 6 - n : 0) << n;
    EXPECT_EQ(st.overLimitMask, 0U) << n;
  }
}

// With autoRecover the cycle that finds TooManyErrors restarts the channel
// itself. While the cable is still cut that START fails: the channel is not
// running, its inputs are not taken for fresh (the interface registers hold
// what START left there), and after recoveryInterval the cycle tries again,
// which brings it back once the cable is.
TEST(HostFaultLimit, AutoRecoverRestartsTheChannelFromTheCycle) {
  lbpkit::SmartSerial::Options o = testing_host::channels(0x03);
  o.autoRecover = true;
  o.recoveryInterval = 100ms;
  lbpkit::SimTransport t;
  const auto info = lbpkit::readCardInfo(t);
  lbpkit::SmartSerial ss(t, info, o);
  ss.discover(0x03);
  ss.startNormal();
  auto& io = t.card().daughtercard(0).fieldIo;
  const auto input = ss.find(kFieldIo, "input");
  const auto output = ss.find(kFieldIo, "output");
  ss.setRaw(output, 0x0101);
  io.setInputVoltage(2, 24.0);
  auto run = [&] {
    const auto start = t.now();
    const auto st = ss.cycle();
    const auto spent = t.now() - start;
    if (spent < 1ms) t.sleep(1ms - spent);
    return std::pair{st, spent};
  };
  for (int i = 0; i < 5; ++i) ASSERT_TRUE(run().first.ok);
  ASSERT_EQ(ss.raw(input) & 0xFF, 0x04U);
  ASSERT_EQ(io.outputs(), 0x0101U);

  auto& link = t.card().part<hm2::Sslbp>().link(kFieldIo);
  link.setConnected(false);
  io.setInputVoltage(2, 0.0);
  int recoveredAt = 0;
  for (int n = 1; n <= 21; ++n) {
    const auto [st, spent] = run();
    if (st.recoveredMask) {
      recoveredAt = n;
      EXPECT_EQ(st.recoveredMask, kBit0);
      EXPECT_FALSE(st.recoveryFailed);
      std::printf("a restart on a cut cable: the cycle took %.1f ms\n",
                  std::chrono::duration<double, std::milli>(spent).count());
    }
  }
  EXPECT_EQ(recoveredAt, 21);
  EXPECT_EQ(ss.recoveries(kFieldIo), 1U);
  EXPECT_FALSE(ss.running(kFieldIo));  // the cable is still cut
  EXPECT_EQ(ss.faultCount(kFieldIo), 0U);

  // Not running: never fresh, the inputs keep their last good value, and
  // the fault count climbs again (to the limit, and a restart every 100 ms).
  for (int n = 0; n < 50; ++n) {
    const auto st = run().first;
    EXPECT_FALSE(st.ok);
    EXPECT_FALSE(st.freshMask & kBit0);
    EXPECT_TRUE(st.freshMask & (1U << kAnalog));
    EXPECT_EQ(ss.raw(input) & 0xFF, 0x04U) << n;
  }
  EXPECT_GT(ss.faultCount(kFieldIo), 0U);

  // The cable back: within the next recovery interval the cycle restarts it.
  link.setConnected(true);
  bool back = false;
  for (int n = 0; n < 200 && !back; ++n) {
    const auto [st, spent] = run();
    if (st.recoveredMask & kBit0) {
      EXPECT_TRUE(ss.running(kFieldIo));
      std::printf("a restart of a good channel: the cycle took %.1f ms\n",
                  std::chrono::duration<double, std::milli>(spent).count());
      back = true;
    }
  }
  ASSERT_TRUE(back);
  EXPECT_EQ(io.outputs(), 0U);  // START cleared the outputs (manual: NORMAL START)
  const auto st = run().first;
  EXPECT_TRUE(st.ok);
  EXPECT_EQ(st.freshMask, 0x03U);
  EXPECT_EQ(ss.raw(input) & 0xFF, 0x00U);
  EXPECT_EQ(io.outputs(), 0x0101U);
  EXPECT_GE(ss.recoveries(kFieldIo), 2U);
}

}  // namespace
