// SPDX-License-Identifier: MIT
// The 7I76's field I/O processor on SSerial channel 3 of
// the 7I77+7I76 firmwares (PIN_7I77_7I76_34.vhd), found and run by the host
// library as `lbpkit discover` and a LinuxCNC cycle do.
#include <gtest/gtest.h>

#include <string>

#include "hostmot2/card.hpp"
#include "lbpkit/faults.hpp"
#include "lbpkit/sserial.hpp"
#include "remote/seven_i76.hpp"
#include "sim_card/sim_transport.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace remote = lbpkit::model::remote;

namespace {

using namespace std::chrono_literals;

constexpr unsigned kChannel = 3;  // PIN_7I77_7I76_34.vhd: the 7I76's field I/O

hm2::HostMot2Card::Options sevenI77SevenI76(const char* card = "7I92") {
  hm2::HostMot2Card::Options o;
  o.card = hm2::cards::find(card);
  o.pinout = hm2::cards::Pinout::SevenI77SevenI76;
  return o;
}

lbpkit::SmartSerial::Options only(std::uint8_t mask, std::uint8_t mode = 0) {
  lbpkit::SmartSerial::Options o;
  o.channelMask = mask;
  o.modes[kChannel] = mode;
  return o;
}

std::vector<std::string> names(const std::vector<lbpkit::ProcessDataElement>& elements) {
  std::vector<std::string> v;
  for (const auto& e : elements) v.push_back(e.name);
  return v;
}

TEST(SevenI76, OnlyTheFirmwaresWithA7I76CarryIt) {
  hm2::HostMot2Card plain;  // the 7I92's default, 7I77x2
  EXPECT_EQ(plain.sevenI76(), nullptr);
  hm2::HostMot2Card withIt(sevenI77SevenI76());
  ASSERT_NE(withIt.sevenI76(), nullptr);
  EXPECT_EQ(withIt.sevenI76()->cardName(), "7I76");
  hm2::HostMot2Card t(sevenI77SevenI76("7I92T"));  // its default firmware
  EXPECT_NE(t.sevenI76(), nullptr);
}

// Discovery finds the 7I76 on channel 3 beside the 7I77's two processors,
// and nothing on its expansion port (channel 4), in every mode with the
// process data sserial(9) lists for it.
TEST(SevenI76, DiscoveryFindsItOnChannel3WithItsProcessData) {
  const std::vector<std::vector<std::string>> expected = {
      {"Input", "Output", "SpinOut", "SpinEna", "SpinDir"},
      {"Input", "Output", "SpinOut", "SpinEna", "SpinDir", "Analog0", "Analog1", "Analog2", "Analog3"},
      {"Input", "Output", "SpinOut", "SpinEna", "SpinDir", "Analog0", "Analog1", "Analog2", "Analog3",
       "FieldVoltage"},
  };
  for (std::uint8_t mode = 0; mode < expected.size(); ++mode) {
    lbpkit::SimTransport t(sevenI77SevenI76());
    const auto info = lbpkit::readCardInfo(t);
    EXPECT_EQ(info.sserialChannels(), 5U);
    lbpkit::SmartSerial ss(t, info, only(0x1B, mode));
    const auto ids = ss.discover(0x1B);
    ASSERT_EQ(ids.size(), 4U);
    EXPECT_EQ(ids[0].name, "7I77");
    EXPECT_EQ(ids[1].name, "7I77");
    ASSERT_TRUE(ids[2].present);
    EXPECT_EQ(ids[2].channel, kChannel);
    EXPECT_EQ(ids[2].name, "7I76");
    EXPECT_EQ(ids[2].unitNumber >> 24, 0x10U);  // mesaflash: GPIO+SPINDLE
    EXPECT_FALSE(ids[3].present);               // channel 4, the expansion port: nothing attached
    ASSERT_EQ(ss.slots(), 3U);
    const auto& d = ss.description(2);
    EXPECT_EQ(names(d.processData), expected[mode]) << "mode " << int(mode);
    EXPECT_EQ(d.outputBits, 16U + 16U + 1U + 1U);
    const auto* spin = d.find("spinout");
    ASSERT_NE(spin, nullptr);
    EXPECT_EQ(spin->type, lbpkit::DataType::Unsigned);
    EXPECT_EQ(spin->direction, lbpkit::Direction::Output);
    EXPECT_FLOAT_EQ(spin->max, 10.0F);
    for (const char* p : {"SwRevision", "NVBaudRate", "NVUnitNumber", "NVWatchDogTimeout"})
      EXPECT_NE(d.find(p), nullptr) << p;
    EXPECT_EQ(d.find("NVEncMode0"), nullptr);  // no MPG counters
  }
}

struct Running7I76 : testing::Test {
  lbpkit::SimTransport t{sevenI77SevenI76()};
  lbpkit::CardInfo info = lbpkit::readCardInfo(t);
  lbpkit::SmartSerial ss{t, info, only(1U << kChannel, 2)};
  remote::SevenI76FieldIo& board = *t.card().sevenI76();

  void SetUp() override {
    ss.discover(1U << kChannel);
    ss.startNormal();
  }
  void cycles(int n) {
    for (int i = 0; i < n; ++i) {
      ASSERT_TRUE(ss.cycle().ok) << lbpkit::describeCs(ss.cs(0));
      t.sleep(1ms);
    }
  }
};

TEST_F(Running7I76, AnInputAtTheTerminalIsReadThroughProcessData) {
  const auto input = ss.find(kChannel, "input");
  ASSERT_TRUE(input.valid());
  cycles(2);
  EXPECT_FALSE(ss.bit(input, 7));
  board.setInputVoltage(7, 24.0);
  board.setInputVoltage(31, 24.0);
  cycles(2);
  EXPECT_TRUE(ss.bit(input, 7));
  EXPECT_TRUE(ss.bit(input, 31));
  EXPECT_FALSE(ss.bit(input, 8));
  board.setInputVoltage(7, 0.0);
  cycles(2);
  EXPECT_FALSE(ss.bit(input, 7));
  // Mode 2's field voltage reading (8 bits, 36.3 V full scale).
  EXPECT_NEAR(ss.value(ss.find(kChannel, "fieldvoltage")), 24.0, 36.3 / 255);
}

TEST_F(Running7I76, AnOutputWrittenAppearsAtTheTerminal) {
  const auto output = ss.find(kChannel, "output");
  ASSERT_TRUE(output.valid());
  ss.setBit(output, 5, true);
  ss.setBit(output, 15, true);
  cycles(2);
  EXPECT_EQ(board.outputs(), (1U << 5) | (1U << 15));
  EXPECT_DOUBLE_EQ(board.outputVoltage(5), 24.0);  // sourcing: at field power
  EXPECT_DOUBLE_EQ(board.outputVoltage(6), 0.0);
  ss.setBit(output, 5, false);
  cycles(2);
  EXPECT_EQ(board.outputs(), 1U << 15);
}

TEST_F(Running7I76, TheSpindleOutputFollowsTheHost) {
  const auto spinout = ss.find(kChannel, "spinout");
  const auto ena = ss.find(kChannel, "spinena");
  const auto dir = ss.find(kChannel, "spindir");
  ASSERT_TRUE(spinout.valid() && ena.valid() && dir.valid());
  for (double volts : {0.0, 2.5, 7.3, 10.0}) {
    ss.set(spinout, volts);
    ss.setRaw(ena, 1);
    ss.setRaw(dir, volts > 5.0);
    cycles(2);
    EXPECT_NEAR(board.spindleVolts(), volts, 10.0 / 65535 + 1e-9) << volts;
    EXPECT_TRUE(board.spindleEnable());
    EXPECT_EQ(board.spindleDirection(), volts > 5.0);
  }
  ss.set(spinout, 12.0);  // beyond the 10 V full scale: clamped
  cycles(2);
  EXPECT_NEAR(board.spindleVolts(), 10.0, 1e-9);
  // The host goes silent: the 7I76's watchdog stops the spindle (0 V, enable off).
  t.sleep(200ms);
  board.advance(hm2::SimTime{t.now()});
  EXPECT_EQ(board.spindleVolts(), 0.0);
  EXPECT_FALSE(board.spindleEnable());
  EXPECT_EQ(board.outputs(), 0U);
}

}  // namespace
