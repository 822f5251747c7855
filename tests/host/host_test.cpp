// SPDX-License-Identifier: MIT
// The host driver library against the in-process virtual card.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <map>

#include "lbpkit/encoders.hpp"
#include "lbpkit/error.hpp"
#include "lbpkit/faults.hpp"
#include "lbpkit/parameters.hpp"
#include "sim_card/sim_transport.hpp"
#include "lbpkit/sserial.hpp"
#include "support/running_card.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

namespace {

using namespace std::chrono_literals;
using lbpkit::Error;

TEST(HostCard, ReadsTheIdromLikeTheRealDriver) {
  lbpkit::SimTransport t;
  const auto info = lbpkit::readCardInfo(t);
  EXPECT_EQ(info.boardName, "MESA7I92");
  EXPECT_EQ(info.ioPorts, 2U);
  EXPECT_EQ(info.portWidth, 17U);
  // Mesa's two-7I77 firmware (PIN_7I77x2_34.vhd): 6 channels whatever is plugged in.
  EXPECT_EQ(info.sserialChannels(), 6U);
  ASSERT_NE(info.module(0xC1), nullptr);
  EXPECT_EQ(info.module(0xC1)->instanceStride, 0x40U);
  EXPECT_EQ(info.pins.at(5).function(), "SSerial 0 TX0 (out)");
  EXPECT_EQ(info.pins.at(7).function(), "MuxedQCountSel 0 SEL0 (out)");
}

TEST(HostCard, NoSmartSerialModuleIsAClearError) {
  lbpkit::SimTransport t;
  auto info = lbpkit::readCardInfo(t);
  info.modules.erase(std::remove_if(info.modules.begin(), info.modules.end(),
                                    [](const lbpkit::ModuleInfo& m) { return m.tag == 0xC1; }),
                     info.modules.end());
  try {
    lbpkit::SmartSerial ss(t, info);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no SSerial module"), std::string::npos) << e.what();
  }
}

TEST(HostDiscovery, BothChannelsEveryModeAndFewDoits) {
  for (std::uint8_t mode = 0; mode < 4; ++mode) {
    lbpkit::SimTransport t;
    const auto info = lbpkit::readCardInfo(t);
    lbpkit::SmartSerial::Options o;
    o.channelMask = 0x07;
    o.modes[0] = mode;
    lbpkit::SmartSerial ss(t, info, o);
    const auto ids = ss.discover(0x07);
    ASSERT_EQ(ids.size(), 3U);
    EXPECT_TRUE(ids[0].present);
    EXPECT_TRUE(ids[1].present);
    EXPECT_FALSE(ids[2].present);  // TB6: nothing attached
    EXPECT_EQ(ids[0].function(), "field I/O");
    EXPECT_EQ(ids[1].function(), "analog");
    ASSERT_EQ(ss.slots(), 2U);
    const auto& io = ss.description(0);
    static constexpr unsigned kIn[] = {32, 64, 72, 88};
    EXPECT_EQ(io.inputBits, kIn[mode]);
    EXPECT_EQ(io.outputBits, 16U);
    ASSERT_NE(io.find("NVWATCHDOGTIME"), nullptr);  // the manual's spelling
    EXPECT_EQ(io.find("NVWATCHDOGTIME")->name, "NVWatchDogTimeout");
    ASSERT_NE(io.find("watchdogtime"), nullptr);
    ASSERT_NE(io.find("FAULT"), nullptr);
    ASSERT_NE(io.find("OUTPUT"), nullptr);
    EXPECT_EQ(ss.description(1).outputBits, 80U);
    // Byte-wise reading (LinuxCNC: one DOIT per byte) would take this many.
    const unsigned bytewise = ss.description(0).bytewiseReads() + ss.description(1).bytewiseReads();
    EXPECT_LE(ss.discoveryStats().doits * 6, bytewise)
        << ss.discoveryStats().doits << " DOITs vs " << bytewise << " byte-wise";
  }
}

TEST(HostDiscovery, AChannelThatFailsToStartNamesItsFault) {
  hm2::HostMot2Card::Options o;
  o.first.fieldIo.vinFromField = false;
  o.first.fieldIo.vin = 24;
  lbpkit::SimTransport t(o);
  t.card().daughtercard(0).fieldIo.setFieldVoltage(1.0, hm2::SimTime{0});
  const auto info = lbpkit::readCardInfo(t);
  lbpkit::SmartSerial::Options so;
  so.channelMask = 0x01;
  lbpkit::SmartSerial ss(t, info, so);
  ss.discover(0x01);
  try {
    ss.startNormal();
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("channel 0"), std::string::npos) << what;
    EXPECT_NE(what.find("LowVoltageFault"), std::string::npos) << what;
  }
}

// A 1 kHz loop through the library for 60 simulated seconds: every output and
// analog value reaches the terminals, every input comes back, injected
// faults are decoded.
TEST(HostCycle, SixtySecondsAt1kHz) {
  testing_host::RunningCard rc;
  auto& t = rc.t;
  auto& ss = rc.ss;
  auto& board = t.card().daughtercard(0);
  lbpkit::MuxedEncoders enc(t, rc.info);
  enc.initialize();
  const auto input = ss.find(0, "input");
  const auto output = ss.find(0, "output");
  std::array<lbpkit::ElementRef, 6> aout;
  for (unsigned i = 0; i < 6; ++i) aout[i] = ss.find(1, "analogout" + std::to_string(i));
  const auto ena = ss.find(1, "analogena");
  const auto spin = ss.find(1, "spinena");
  ASSERT_TRUE(input.valid() && output.valid() && ena.valid() && spin.valid());
  t.card().part<hm2::MuxedEncoder>().setVelocity(3, 5000, hm2::SimTime{t.now()});

  unsigned outputsSeen = 0, inputsSeen = 0, faultsDecoded = 0;
  std::uint32_t inputMask = 0;
  const auto begin = t.now();
  for (int cycle = 0; cycle < 60000; ++cycle) {
    const auto start = t.now();
    const unsigned k = static_cast<unsigned>(cycle / 100);
    ss.setRaw(output, 1ULL << (k % 16));
    const double volts = -10.0 + 20.0 * ((cycle % 1000) / 999.0);
    for (unsigned i = 0; i < 6; ++i) ss.set(aout[i], i % 2 ? -volts : volts);
    ss.setRaw(ena, (k % 2));
    ss.setRaw(spin, (k % 3) == 0);
    // The world: one input at a time goes high.
    board.fieldIo.setInputVoltage(k % 32, 24.0);
    board.fieldIo.setInputVoltage((k + 31) % 32, 0.0);
    // A short on output 15 for a while, then removed and cleared by a restart.
    if (cycle == 30000) board.fieldIo.setOutputLoad(15, 1.0);
    ss.queueOutputs();
    enc.queue();
    t.flush();
    const auto st = ss.collectInputs();
    enc.update();
    ASSERT_TRUE(st.ok || cycle >= 30000) << "cycle " << cycle << ": " << lbpkit::describeCs(ss.cs(0));
    if (board.fieldIo.outputs() == (1U << (k % 16))) ++outputsSeen;
    const std::uint32_t in = static_cast<std::uint32_t>(ss.raw(input));
    if (in & (1U << (k % 32))) {
      ++inputsSeen;
      inputMask |= in;
    }
    if (std::abs(board.analog.outputVoltage(0) - volts) < 20.0 / 8191 + 1e-9 &&
        std::abs(board.analog.outputVoltage(1) + volts) < 20.0 / 8191 + 1e-9 &&
        board.analog.enable(0) == (k % 2 == 1) && board.analog.enable(5) == ((k % 3) == 0))
      ++outputsSeen;
    if (ss.remoteFaults(0) & 0x08) {
      EXPECT_EQ(lbpkit::describeRemoteFaults(ss.remoteFaults(0)), "OverCurrentFault");
      ++faultsDecoded;
      if (faultsDecoded == 10) {
        board.fieldIo.setOutputLoad(15, 1e9);
        EXPECT_TRUE(ss.recover(0));   // stop + start clears the fault
        EXPECT_FALSE(ss.recover(0));  // rate limited
      }
    }
    const auto spent = t.now() - start;
    ASSERT_LT(spent, 1ms) << "cycle " << cycle;
    t.sleep(1ms - spent);
  }
  EXPECT_NEAR(std::chrono::duration<double>(t.now() - begin).count(), 60.0, 1e-6);
  EXPECT_GT(outputsSeen, 2 * 60000 - 2000U);  // both checks nearly every cycle
  EXPECT_GT(inputsSeen, 60000 - 700U);
  EXPECT_EQ(inputMask, 0xFFFFFFFFU);  // every input came back
  EXPECT_GE(faultsDecoded, 10U);
  EXPECT_NEAR(static_cast<double>(enc.counts(3)), 5000.0 * 60, 10);
  EXPECT_NEAR(enc.velocity(3), 5000, 50);
}

// Over a network every poll of COMMAND costs a round trip; the wait before
// the first poll must follow the DOIT's real duration, not grow cycle after
// cycle (it once did, until a cycle took 200 ms).
TEST(HostCycle, DoitWaitStaysBoundedOverASlowLink) {
  testing_host::RunningCard rc;
  auto& t = rc.t;
  auto& ss = rc.ss;
  t.setExchangeLatency(std::chrono::microseconds(120));
  const auto exchanges0 = t.exchanges();
  lbpkit::Nanoseconds longest{0};
  for (int cycle = 0; cycle < 2000; ++cycle) {
    const auto start = t.now();
    ASSERT_TRUE(ss.cycle().ok) << "cycle " << cycle;
    longest = std::max(longest, t.now() - start);
    t.sleep(lbpkit::Nanoseconds{1ms} - std::min<lbpkit::Nanoseconds>(1ms, t.now() - start));
  }
  EXPECT_LT(longest, 800us);
  EXPECT_LE(t.exchanges() - exchanges0, 2000U * 4);
}

// A remote with bad discovery data: every case gets an error that names what
// is wrong and where, and nothing hangs.
struct FakeRemote final : lbpkit::RemoteAccess {
  std::array<std::uint8_t, 65536> mem{};
  std::uint64_t count = 0;
  std::uint64_t read(std::uint16_t a, unsigned size) override {
    ++count;
    std::uint64_t v = 0;
    for (unsigned i = 0; i < size; ++i) v |= static_cast<std::uint64_t>(mem[(a + i) & 0xFFFF]) << (8 * i);
    return v;
  }
  void write(std::uint16_t, unsigned, std::uint64_t) override {}
  std::uint8_t localRead(std::uint8_t) override { return 0; }
  void localWrite(std::uint8_t, std::uint8_t) override {}
  [[nodiscard]] std::uint64_t transactions() const override { return count; }
  [[nodiscard]] std::string where() const override { return "fake channel 5"; }

  void u16(std::uint16_t a, std::uint16_t v) {
    mem[a] = static_cast<std::uint8_t>(v);
    mem[a + 1] = static_cast<std::uint8_t>(v >> 8);
  }
  // A PDD record at `a`.
  void pdd(std::uint16_t a, std::uint8_t bits, std::uint8_t type, std::uint8_t dir, const char* unit,
           const char* name, std::uint16_t addr = 0x200) {
    mem[a] = 0xA0;
    mem[a + 1] = bits;
    mem[a + 2] = type;
    mem[a + 3] = dir;
    const float mn = 0, mx = 10;
    std::memcpy(&mem[a + 4], &mn, 4);
    std::memcpy(&mem[a + 8], &mx, 4);
    u16(static_cast<std::uint16_t>(a + 12), addr);
    std::strcpy(reinterpret_cast<char*>(&mem[a + 14]), unit);
    std::strcpy(reinterpret_cast<char*>(&mem[a + 15 + std::strlen(unit)]), name);
  }
};

std::string discoveryError(FakeRemote& r, std::uint16_t ptoc, std::uint16_t gtoc, std::optional<unsigned> rx = {},
                           std::optional<unsigned> tx = {}) {
  try {
    lbpkit::discover(r, ptoc, gtoc, rx, tx);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(HostDiscovery, BadTablesGiveClearErrors) {
  {
    FakeRemote r;  // a good one first
    r.u16(0x100, 0x200);
    r.u16(0x102, 0);
    r.pdd(0x200, 16, 0x01, 0x80, "none", "Output");
    const auto d = lbpkit::discover(r, 0x100, 0, 1, 2);
    ASSERT_EQ(d.processData.size(), 1U);
    EXPECT_NE(discoveryError(r, 0x100, 0, 1, 3).find("discovery RPC says 3"), std::string::npos);
    EXPECT_NE(discoveryError(r, 0x100, 0, 4, 2).find("discovery RPC says 4"), std::string::npos);
  }
  {
    FakeRemote r;
    r.u16(0x100, 0x200);
    r.mem[0x200] = 0xC5;
    const auto e = discoveryError(r, 0x100, 0);
    EXPECT_NE(e.find("unknown type 0xC5"), std::string::npos) << e;
    EXPECT_NE(e.find("PTOC entry 0"), std::string::npos) << e;
    EXPECT_NE(e.find("0x0200"), std::string::npos) << e;
    EXPECT_NE(e.find("fake channel 5"), std::string::npos) << e;
  }
  {
    FakeRemote r;  // unterminated name
    r.u16(0x100, 0x200);
    r.pdd(0x200, 8, 0x02, 0x00, "V", "X");
    std::memset(&r.mem[0x210], 'A', 200);
    const auto e = discoveryError(r, 0x100, 0);
    EXPECT_NE(e.find("unterminated or longer than 48"), std::string::npos) << e;
  }
  {
    FakeRemote r;  // pointer loop: the table points at the same record twice
    r.u16(0x100, 0x200);
    r.u16(0x102, 0x200);
    r.pdd(0x200, 8, 0x02, 0x00, "V", "X");
    EXPECT_NE(discoveryError(r, 0x100, 0).find("pointer loop"), std::string::npos);
  }
  {
    FakeRemote r;  // a table with no end
    for (std::uint16_t i = 0; i < 200; ++i) r.u16(static_cast<std::uint16_t>(0x100 + 2 * i), static_cast<std::uint16_t>(0x1000 + 32 * i));
    EXPECT_NE(discoveryError(r, 0x100, 0).find("no 0 sentinel"), std::string::npos);
  }
  {
    FakeRemote r;  // out of range pointer
    r.u16(0x100, 0xFFFA);
    EXPECT_NE(discoveryError(r, 0x100, 0).find("out of range"), std::string::npos);
  }
  {
    FakeRemote r;  // an element over 96 bits
    r.u16(0x100, 0x200);
    r.pdd(0x200, 128, 0x06, 0x00, "none", "Big");
    EXPECT_NE(discoveryError(r, 0x100, 0).find("128 bits is over the 96"), std::string::npos);
  }
  {
    FakeRemote r;  // elements that add up to too much
    r.u16(0x100, 0x200);
    r.u16(0x102, 0x240);
    r.pdd(0x200, 64, 0x01, 0x00, "none", "A");
    r.pdd(0x240, 64, 0x01, 0x00, "none", "B", 0x210);
    EXPECT_NE(discoveryError(r, 0x100, 0).find("does not fit 96 bits"), std::string::npos);
  }
  {
    FakeRemote r;  // bad direction, unknown type, NV in PTOC
    r.u16(0x100, 0x200);
    r.pdd(0x200, 8, 0x02, 0x33, "V", "X");
    EXPECT_NE(discoveryError(r, 0x100, 0).find("invalid data direction 0x33"), std::string::npos);
    r.pdd(0x200, 8, 0x0E, 0x00, "V", "X");
    EXPECT_NE(discoveryError(r, 0x100, 0).find("unknown data type 0x0E"), std::string::npos);
    r.pdd(0x200, 8, 0x04, 0x00, "V", "X");
    EXPECT_NE(discoveryError(r, 0x100, 0).find("non-volatile"), std::string::npos);
  }
  {
    FakeRemote r;
    EXPECT_NE(discoveryError(r, 0, 0).find("no PTOC"), std::string::npos);
  }
}

TEST(HostEncoders, VelocityFallsToZeroWhenTheEncoderStops) {
  lbpkit::SimTransport t;
  const auto info = lbpkit::readCardInfo(t);
  lbpkit::MuxedEncoders enc(t, info);
  enc.initialize();
  t.card().part<hm2::MuxedEncoder>().setVelocity(0, 10000, hm2::SimTime{t.now()});
  t.card().part<hm2::MuxedEncoder>().setVelocity(1, 5, hm2::SimTime{t.now()});  // slower than the timestamps span
  for (int i = 0; i < 3000; ++i) {
    enc.queue();
    t.flush();
    enc.update();
    t.sleep(1ms);
  }
  EXPECT_NEAR(enc.velocity(0), 10000, 100);
  EXPECT_NEAR(enc.velocity(1), 5, 1);
  t.card().part<hm2::MuxedEncoder>().setVelocity(0, 0, hm2::SimTime{t.now()});
  for (int i = 0; i < 1000; ++i) {
    enc.queue();
    t.flush();
    enc.update();
    t.sleep(1ms);
  }
  EXPECT_EQ(enc.velocity(0), 0.0);
}

TEST(HostParameters, ParseAndFormat) {
  lbpkit::ProcessDataElement wd{"WatchDogTime", "mS", lbpkit::DataType::Unsigned, lbpkit::Direction::Bidirectional,
                                16, 0, 65535, 0x200, 0};
  EXPECT_EQ(lbpkit::parseElement(wd, "100", false), 100U);
  EXPECT_EQ(lbpkit::parseElement(wd, "64", true), 100U);
  EXPECT_EQ(lbpkit::parseElement(wd, "0x64", false), 100U);
  EXPECT_THROW(lbpkit::parseElement(wd, "70000", false), Error);
  EXPECT_THROW(lbpkit::parseElement(wd, "-1", false), Error);
  EXPECT_THROW(lbpkit::parseElement(wd, "12abc", false), Error);
  EXPECT_EQ(lbpkit::formatElement(wd, 100, true), "0064");
  lbpkit::ProcessDataElement s{"A", "V", lbpkit::DataType::Signed, lbpkit::Direction::Output, 13, -10, 10, 0, 0};
  EXPECT_EQ(lbpkit::formatElement(s, 0x1FFF, false), "-1");
  EXPECT_EQ(lbpkit::parseElement(s, "4095", false), 4095U);
  EXPECT_THROW(lbpkit::parseElement(s, "5000", false), Error);  // over 2^12-1: would read as negative
  EXPECT_EQ(lbpkit::parseElement(s, "-4096", false), 0x1000U);
  EXPECT_EQ(s.unscale(10.0), 4095U);
  EXPECT_EQ(s.unscale(-10.0), 0x1FFFU & static_cast<std::uint64_t>(-4095));
  EXPECT_DOUBLE_EQ(s.scale(4095), 10.0);
  EXPECT_DOUBLE_EQ(s.scale(0), 0.0);
  lbpkit::ProcessDataElement u{"F", "V", lbpkit::DataType::Unsigned, lbpkit::Direction::Input, 8, 0, 36.3F, 0, 0};
  EXPECT_NEAR(u.scale(255), 36.3, 1e-5);
  EXPECT_EQ(u.unscale(36.3), 255U);
}

TEST(HostFaults, Names) {
  EXPECT_EQ(lbpkit::describeCs(0), "ok");
  EXPECT_EQ(lbpkit::describeCs(0x01002108), "TimeoutError RemoteFault CommunicationError WatchdogFault");
  EXPECT_EQ(lbpkit::describeRemoteFaults(0x30), "HighVoltageFault LowVoltageFault");
}

}  // namespace

// As LinuxCNC's num_encoders: the first `used` counters only, each one fewer
// read a cycle; more than the IDROM declares is an error naming both.
TEST(HostEncoders, OnlyTheCountersInUseAreRead) {
  testing_host::RunningCard rc;
  auto& t = rc.t;
  lbpkit::MuxedEncoders all(t, rc.info);
  lbpkit::MuxedEncoders six(t, rc.info, 6);
  EXPECT_EQ(all.size(), 12U);  // 7i92_7i77x2: two 7I77s' worth
  EXPECT_EQ(six.size(), 6U);
  auto cycleTime = [&](lbpkit::MuxedEncoders& e) {
    const auto start = t.now();
    e.queue();
    t.flush();
    EXPECT_TRUE(e.update());
    return t.now() - start;
  };
  EXPECT_LT(cycleTime(six), cycleTime(all));  // each access takes the card's time
  t.card().part<hm2::MuxedEncoder>().setVelocity(5, 4000, hm2::SimTime{t.now()});
  t.sleep(std::chrono::milliseconds(10));
  cycleTime(six);
  EXPECT_GT(six.counts(5), 30);
  try {
    lbpkit::MuxedEncoders thirteen(t, rc.info, 13);
    ADD_FAILURE() << "13 of 12 counters accepted";
  } catch (const lbpkit::Error& e) {
    EXPECT_NE(std::string(e.what()).find("13 muxed encoders asked for"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("has 12"), std::string::npos) << e.what();
  }
}
