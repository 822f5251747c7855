// SPDX-License-Identifier: MIT
#include <gtest/gtest.h>

#include "support/lbp_host.hpp"
#include "remote/analog.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace remote = lbpkit::model::remote;
namespace lbp = lbpkit::model::lbp;

namespace {

using remote::AnalogProcessor;
using testing_lbp::Bytes;
using testing_lbp::Host;
using namespace std::chrono_literals;

// Six 13-bit codes, AnalogEna at bit 78, SpinEna at bit 79.
Bytes pack(std::array<int, 6> codes, bool ena, bool spin) {
  Bytes out(10, 0);
  for (unsigned i = 0; i < 6; ++i)
    lbp::packBits(out, i * 13, 13, static_cast<std::uint64_t>(codes[i]) & 0x1FFF);
  lbp::packBits(out, 78, 1, ena);
  lbp::packBits(out, 79, 1, spin);
  return out;
}

void start(Host& h) {
  ASSERT_TRUE(h.setLocal(lbp::local_write::kRemoteSwMode, 0));
  h.processData(Bytes(10, 0));
  ASSERT_TRUE(h.setLocal(lbp::local_write::kClearFault, 0xFF));
}

TEST(Analog, ZeroVoltsAndEnablesOffAtPowerUp) {
  AnalogProcessor a;
  Host h(a);
  h.processData(pack({4095, 4095, 4095, 4095, 4095, 4095}, true, true));
  for (unsigned ch = 0; ch < 6; ++ch) {
    EXPECT_DOUBLE_EQ(a.outputVoltage(ch), 0.0);
    EXPECT_FALSE(a.enable(ch));
  }
}

TEST(Analog, ThirteenBitResolutionAndEnables) {
  AnalogProcessor a;
  Host h(a);
  start(h);
  h.processData(pack({4095, -4096, 1, -1, 2048, 0}, true, false));
  EXPECT_DOUBLE_EQ(a.outputVoltage(0), 10.0);
  EXPECT_DOUBLE_EQ(a.outputVoltage(1), -10.0);  // -4096 clamps to the output range
  EXPECT_NEAR(a.outputVoltage(2), 10.0 / 4095, 1e-12);  // one step: 2.44 mV
  EXPECT_NEAR(a.outputVoltage(3), -10.0 / 4095, 1e-12);
  EXPECT_NEAR(a.outputVoltage(4), 5.0012, 1e-4);
  EXPECT_EQ(a.dacCode(1), -4096);
  for (unsigned ch = 0; ch < 5; ++ch) EXPECT_TRUE(a.enable(ch));
  EXPECT_FALSE(a.enable(5));  // ENA5 follows SpinEna alone
  h.processData(pack({0, 0, 0, 0, 0, 0}, false, true));
  EXPECT_FALSE(a.enable(0));
  EXPECT_TRUE(a.enable(5));
}

TEST(Analog, MoreThan50msWithoutTheHostDropsEverything) {
  AnalogProcessor a;
  Host h(a);
  start(h);
  h.processData(pack({1000, 1000, 1000, 1000, 1000, 1000}, true, true));
  h.wait(40ms);
  h.processData(pack({1000, 1000, 1000, 1000, 1000, 1000}, true, true));
  h.wait(40ms);
  EXPECT_GT(a.outputVoltage(0), 2.0);
  h.wait(11ms);
  for (unsigned ch = 0; ch < 6; ++ch) {
    EXPECT_DOUBLE_EQ(a.outputVoltage(ch), 0.0);
    EXPECT_FALSE(a.enable(ch));
  }
  EXPECT_EQ(a.faults(), remote::fault::kWatchdog);
}

// FIELD I/O WATCHDOG AND FAULTS: "When a fault flag is set, outputs can not
// longer be set and the host must first clear the fault"; ANALOG SECTION
// WATCHDOG: outputs "set to 0V and drive enable OPTO couplers turned off".
// What the host writes while bitten is not set: the fault clear alone
// brings back neither volts nor enables; the next write does.
TEST(Analog, WritesWhileTheWatchdogFaultIsSetAreNotSet) {
  AnalogProcessor a;
  Host h(a);
  start(h);
  h.wait(51ms);
  ASSERT_EQ(a.faults(), remote::fault::kWatchdog);
  h.processData(pack({2000, 2000, 2000, 2000, 2000, 2000}, true, true));
  EXPECT_DOUBLE_EQ(a.outputVoltage(0), 0.0);
  ASSERT_TRUE(h.setLocal(lbp::local_write::kClearFault, 0xFF));
  EXPECT_EQ(a.faults(), 0);
  for (unsigned ch = 0; ch < 6; ++ch) {
    EXPECT_DOUBLE_EQ(a.outputVoltage(ch), 0.0) << ch;
    EXPECT_FALSE(a.enable(ch)) << ch;
  }
  h.processData(pack({2000, 2000, 2000, 2000, 2000, 2000}, true, true));
  EXPECT_GT(a.outputVoltage(0), 4.8);
  EXPECT_TRUE(a.enable(0));
  EXPECT_TRUE(a.enable(5));
}

}  // namespace
