// SPDX-License-Identifier: MIT
// A host that stalls: for every stall length around the 7I77's
// 50 ms watchdogs and the HostMot2 watchdog, in simulated time, the outputs
// go off within the timeout and come back only as the manual allows.
//
// 7I77 manual, FIELD I/O WATCHDOG AND FAULTS: "Default watchdog time is 50 mS
// which means if not accessed at a greater than 20 Hz rate, the watchdog
// will bite and disable the outputs. When a fault flag is set, outputs can
// not longer be set and the host must first clear the fault before normal
// operation can continue. ... This is normally handled by SSLBP" (its START
// clears the faults). The analog processor's enables and outputs do the
// same. The HostMot2 watchdog (hostmot2(9): LinuxCNC arms it at 5 ms) bites
// when no host write pets it in time and stays bitten until the host clears
// its status.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <string>

#include "hostmot2/watchdog.hpp"
#include "lbpkit/wire/seven_i77.hpp"
#include "support/running_card.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

namespace {

using namespace std::chrono_literals;
using Ns = std::chrono::nanoseconds;

constexpr auto kPeriod = 1ms;
constexpr auto kRemoteWatchdog = 50ms;     // WATCHDOGTIME's default (manual: WATCHDOG TIMEOUT)
constexpr auto kHm2Watchdog = 5ms;         // what LinuxCNC's hostmot2 arms
constexpr std::uint32_t kHm2Ticks = 499'999;  // 5 ms at the 7I92's 100 MHz
constexpr std::uint8_t kWatchdogFault = lbpkit::wire::i7i77::fault::kWatchdog;

struct Host {
  testing_host::RunningCard rc;
  lbpkit::ElementRef output = rc.ss.find(0, "output");
  lbpkit::ElementRef enable = rc.ss.find(1, "analogena");
  lbpkit::ElementRef aout = rc.ss.find(1, "analogout0");
  Ns lastDoit{0};

  Host() {
    setOutputs();
    const std::uint32_t ticks = kHm2Ticks, clear = 0;
    rc.t.queueWrite(hm2::Watchdog::kTimer, &ticks);
    rc.t.queueWrite(hm2::Watchdog::kStatus, &clear);
    rc.t.flush();
    for (int i = 0; i < 100; ++i) cycle();
  }
  void setOutputs() {
    rc.ss.setRaw(output, 0x0009);  // outputs 0 and 3
    rc.ss.setRaw(enable, 1);
    rc.ss.set(aout, 5.0);
  }
  // One servo period: the outputs and DOIT, the HostMot2 watchdog petted in
  // the same exchange (as hm2's write function does), the inputs.
  lbpkit::CycleStatus cycle() {
    const auto start = rc.t.now();
    rc.ss.queueOutputs();
    const std::uint32_t pet = 0x5A000000;
    rc.t.queueWrite(hm2::Watchdog::kReset, &pet);
    rc.t.flush();
    lastDoit = rc.t.now();
    const auto s = rc.ss.collectInputs();
    rc.t.sleep(start + kPeriod - rc.t.now());
    return s;
  }
  hm2::HostMot2Card& card() { return rc.t.card(); }
  bool fieldOutputsOn() { return card().daughtercard(0).fieldIo.outputOn(3); }
  bool analogOn() {
    auto& a = card().daughtercard(0).analog;
    return a.enable(0) && a.outputVoltage(0) > 4.9;
  }
  bool hm2Bitten() { return card().part<hm2::Watchdog>().state(hm2::SimTime{rc.t.now()}).bitten; }
};

TEST(HostStall, OutputsGoOffWithinTheTimeoutAndComeBackOnlyAsTheManualAllows) {
  const int stallsMs[] = {2, 4, 6, 10, 25, 45, 48, 49, 50, 51, 52, 55, 60, 100, 250, 1000};
  for (const int ms : stallsMs) {
    SCOPED_TRACE("stall of " + std::to_string(ms) + " ms");
    Host h;
    ASSERT_TRUE(h.fieldOutputsOn());
    ASSERT_TRUE(h.analogOn());
    ASSERT_FALSE(h.hm2Bitten());
    // The stall: nothing from the host; time passes in 100 us steps and the
    // moment each watchdog acts is taken.
    const auto stallStart = h.rc.t.now();
    const auto lastDoit = h.lastDoit;
    Ns fieldOff{-1}, analogOff{-1}, hm2Bit{-1};
    while (h.rc.t.now() - stallStart < std::chrono::milliseconds(ms)) {
      h.rc.t.sleep(100us);
      h.card().advance(hm2::SimTime{h.rc.t.now()});
      const auto since = h.rc.t.now() - lastDoit;
      if (fieldOff < Ns{0} && !h.fieldOutputsOn()) fieldOff = since;
      if (analogOff < Ns{0} && !h.analogOn()) analogOff = since;
      if (hm2Bit < Ns{0} && h.hm2Bitten()) hm2Bit = since;
    }
    const auto stalled = h.rc.t.now() - lastDoit;
    // Off within the timeout of the last DOIT (give or take a 100 us step
    // and the DOIT's own transfer), and not before it.
    if (stalled > kRemoteWatchdog + 1ms) {
      ASSERT_GE(fieldOff, Ns{0}) << "the field outputs stayed on";
      ASSERT_GE(analogOff, Ns{0}) << "the analog outputs stayed on";
      EXPECT_LE(fieldOff, kRemoteWatchdog + 1ms);
      EXPECT_LE(analogOff, kRemoteWatchdog + 1ms);
    }
    if (fieldOff >= Ns{0}) {
      EXPECT_GE(fieldOff, kRemoteWatchdog - 1ms);
    }
    if (stalled < kRemoteWatchdog - 1ms) {
      EXPECT_LT(fieldOff, Ns{0}) << "the 7I77 bit before its 50 ms";
      EXPECT_LT(analogOff, Ns{0});
    }
    if (stalled > kHm2Watchdog + 1ms) {
      ASSERT_GE(hm2Bit, Ns{0}) << "the HostMot2 watchdog did not bite";
      EXPECT_LE(hm2Bit, kHm2Watchdog + 1ms);
    }
    if (stalled < kHm2Watchdog - 1ms) {
      EXPECT_LT(hm2Bit, Ns{0});
    }
    // The host comes back. Its first cycle may land just after a watchdog's
    // time (a stall that ended within a period of it): what it finds then is
    // what the rest of the run must keep. Cycles alone do not bring the
    // outputs back after a bite (the fault flag holds them off), nor clear
    // the HostMot2 watchdog's bite.
    h.cycle();
    const bool remoteBit = !h.fieldOutputsOn();
    const bool hostBit = h.hm2Bitten();
    if (fieldOff >= Ns{0}) {
      EXPECT_TRUE(remoteBit);
    }
    if (hm2Bit >= Ns{0}) {
      EXPECT_TRUE(hostBit);
    }
    for (int i = 0; i < 20; ++i) h.cycle();
    EXPECT_EQ(h.fieldOutputsOn(), !remoteBit);
    EXPECT_EQ(h.analogOn(), !remoteBit);
    EXPECT_EQ(h.hm2Bitten(), hostBit);
    if (remoteBit) {
      EXPECT_NE(h.rc.ss.remoteFaults(0) & kWatchdogFault, 0) << "the field I/O processor reports its watchdog fault";
    }
    // Clearing them as the manual says: the HostMot2 watchdog's status
    // written to 0, and SSLBP's START (which clears the remotes' faults).
    const std::uint32_t clear = 0;
    h.rc.t.queueWrite(hm2::Watchdog::kStatus, &clear);
    h.rc.t.flush();
    if (remoteBit) {
      h.rc.ss.startNormal();  // STOP ALL, START: SSLBP clears the faults
      h.setOutputs();         // a new start begins from zeroed process data
    }
    for (int i = 0; i < 20; ++i) h.cycle();
    EXPECT_TRUE(h.fieldOutputsOn());
    EXPECT_TRUE(h.analogOn());
    EXPECT_FALSE(h.hm2Bitten());
    const auto after = [](Ns t, bool bit, const std::string& what, const char* quiet) {
      return !bit ? std::string(quiet)
                  : t >= Ns{0} ? what + " after " + std::to_string(t.count() / 1000) + " us of silence"
                               : what + " as the host came back";
    };
    std::printf("stall %4d ms (%5lld us since the last DOIT): 7I77 outputs %s; HostMot2 watchdog %s\n", ms,
                static_cast<long long>(stalled.count() / 1000), after(fieldOff, remoteBit, "off", "kept").c_str(),
                after(hm2Bit, hostBit, "bit", "quiet").c_str());
  }
}

}  // namespace
