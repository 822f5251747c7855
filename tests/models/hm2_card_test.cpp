// SPDX-License-Identifier: MIT
// The card as drivers see it: IDROM parsed the way LinuxCNC's hostmot2 and
// mesaflash parse it; the watchdog; the muxed encoders.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "support/card_host.hpp"
#include "lbp/protocol.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace remote = lbpkit::model::remote;
namespace lbp = lbpkit::model::lbp;

namespace {

using namespace std::chrono_literals;

using namespace testing_hm2;

std::string chars(std::uint32_t w) {
  std::string s;
  for (int i = 0; i < 4; ++i) s.push_back(static_cast<char>(w >> (8 * i)));
  return s;
}

struct Md {
  std::uint8_t gtag, version, clock, instances;
  std::uint16_t base;
  std::uint8_t registers, regStrideSel, instStrideSel;
  std::uint32_t mp;
};

TEST(Idrom, ParsesLikeTheHostmot2Driver) {
  using Pinout = hm2::HostMot2Card::Pinout;
  // Mesa's two-7I77 firmware with one and with two 7I77s (the same IDROM),
  // and the 7I77 + GPIO layout.
  for (int variant : {0, 1, 2}) {
    const bool x2 = variant < 2;
    hm2::HostMot2Card::Options o;
    o.pinout = x2 ? Pinout::SevenI77x2 : Pinout::SevenI77Gpio;
    if (variant == 1) o.second = hm2::HostMot2Card::DaughterOptions{};
    hm2::HostMot2Card card(o);
    CardHost h{card};
    ASSERT_EQ(h.read(0x0100), 0x55AACAFEU);
    EXPECT_EQ(chars(h.read(0x0104)) + chars(h.read(0x0108)), "HOSTMOT2");
    const auto idrom = static_cast<std::uint16_t>(h.read(0x010C) & 0xFFFF);
    ASSERT_EQ(idrom, 0x0400);
    auto word = [&](unsigned off) { return h.read(static_cast<std::uint16_t>(idrom + off)); };
    const auto type = word(0);
    EXPECT_TRUE(type == 2 || type == 3);
    EXPECT_EQ(chars(word(0x0C)) + chars(word(0x10)), "MESA7I92");
    const auto ioPorts = word(0x1C), ioWidth = word(0x20), portWidth = word(0x24);
    EXPECT_EQ(portWidth, 17U);  // hm2_eth's 7I92: 2 connectors of 17 pins
    EXPECT_EQ(ioPorts, 2U);
    EXPECT_EQ(ioWidth, ioPorts * portWidth);
    EXPECT_GE(word(0x28), 1'000'000U);
    EXPECT_GE(word(0x2C), 1'000'000U);
    const std::uint32_t instStride[2] = {word(0x30), word(0x34)};
    const std::uint32_t regStride[2] = {word(0x38), word(0x3C)};
    // Module descriptors until a zero tag; each checked as the driver does.
    std::vector<Md> mds;
    for (unsigned i = 0; i < 32; ++i) {
      const auto w0 = word(word(4) + 12 * i), w1 = word(word(4) + 12 * i + 4), w2 = word(word(4) + 12 * i + 8);
      Md m{static_cast<std::uint8_t>(w0), static_cast<std::uint8_t>(w0 >> 8), static_cast<std::uint8_t>(w0 >> 16),
           static_cast<std::uint8_t>(w0 >> 24), static_cast<std::uint16_t>(w1), static_cast<std::uint8_t>(w1 >> 16),
           static_cast<std::uint8_t>((w1 >> 24) & 0xF), static_cast<std::uint8_t>(w1 >> 28), w2};
      if (m.gtag == 0) break;
      EXPECT_TRUE(m.clock == 1 || m.clock == 2) << int(m.gtag);
      ASSERT_LE(m.regStrideSel, 1);
      ASSERT_LE(m.instStrideSel, 1);
      mds.push_back(m);
    }
    auto consistent = [&](std::uint8_t gtag, std::uint8_t version, std::uint8_t regs, std::uint32_t stride,
                          std::uint32_t mp) {
      for (const auto& m : mds)
        if (m.gtag == gtag)
          return m.version == version && m.registers == regs && instStride[m.instStrideSel] == stride &&
                 regStride[m.regStrideSel] == 0x100 && m.mp == mp;
      return false;
    };
    EXPECT_TRUE(consistent(0x02, 0, 3, 4, 0x0));        // WatchDog
    EXPECT_TRUE(consistent(0x03, 0, 5, 4, 0x1F));       // IOPort
    EXPECT_TRUE(consistent(0x0C, 3, 5, 4, 0x3));        // MuxedQCount
    EXPECT_TRUE(consistent(0xC1, 0, 6, 0x40, 0x3C));    // SmartSerial
    EXPECT_TRUE(consistent(0x80, 0, 1, 4, 0x0));        // LED
    for (const auto& m : mds) {
      if (m.gtag == 0x03) {
        EXPECT_EQ(m.instances, ioPorts);
      }
      // PIN_7I77x2_34.vhd: 12 MuxedQCount, one MuxedQCountSel, one SSerial.
      if (m.gtag == 0x0C) {
        EXPECT_EQ(m.instances, x2 ? 12 : 6) << variant;
      }
      if (m.gtag == 0x0D || m.gtag == 0xC1) {
        EXPECT_EQ(m.instances, 1) << variant;
      }
    }
    // Pin descriptors: primary IOPort for all; the manual's P1 table on IO0..16.
    std::vector<std::uint32_t> pins;
    for (unsigned i = 0; i < ioWidth; ++i) pins.push_back(word(word(8) + 4 * i));
    for (auto p : pins) EXPECT_EQ(p >> 24, 0x03U);
    auto fn = [&](unsigned io) { return pins[io] & 0x00FFFFFFU; };  // unit, tag, pin
    EXPECT_EQ(fn(0), 0x00C193U);   // IO0 SS2TXEN
    EXPECT_EQ(fn(1), 0x00C183U);   // IO1 SS2TX
    EXPECT_EQ(fn(2), 0x00C103U);   // IO2 SS2RX
    EXPECT_EQ(fn(3), 0x00C182U);   // IO3 SS1TX
    EXPECT_EQ(fn(4), 0x00C102U);   // IO4 SS1RX
    EXPECT_EQ(fn(5), 0x00C181U);   // IO5 SS0TX
    EXPECT_EQ(fn(6), 0x00C101U);   // IO6 SS0RX
    EXPECT_EQ(fn(7), 0x000D81U);   // IO7 ENCMUX
    EXPECT_EQ(fn(8), 0x000C01U);   // IO8 QCMUXA01
    EXPECT_EQ(fn(9), 0x000C02U);   // IO9 QCMUXB01
    EXPECT_EQ(fn(10), 0x000C03U);  // IO10 QCMUXI01
    EXPECT_EQ(fn(13), 0x010C03U);  // IO13 QCMUXI23
    EXPECT_EQ(fn(16), 0x020C03U);  // IO16 QCMUXI45
    if (x2) {
      // The second connector as PIN_7I77x2_34.vhd has it, 7I77 or not.
      EXPECT_EQ(fn(17), 0x00C196U);  // SS5TXEN on the second connector
      EXPECT_EQ(fn(18), 0x00C186U);  // SS5TX
      EXPECT_EQ(fn(19), 0x00C106U);  // SS5RX
      EXPECT_EQ(fn(23), 0x00C104U);  // SS3RX
      EXPECT_EQ(fn(24), 0x060D81U);  // second ENCMUX: unit 6, as the firmware has it
      EXPECT_EQ(fn(25), 0x030C01U);  // pair 3 (counters 6, 7)
      EXPECT_EQ(fn(33), 0x050C03U);
    } else {
      EXPECT_EQ(fn(17), 0U);  // plain GPIO
      EXPECT_EQ(fn(33), 0U);
    }
  }
}

// With one 7I77 on Mesa's two-7I77 firmware, the second connector's SSerial
// channels are there but nobody answers: START reports channels 2..5
// failed, 0 and 1 run; the muxed counters 6..11 count (they are the
// firmware's whether a 7I77 is plugged in or not).
TEST(Card, TheTwo7I77FirmwareWithOne7I77HasSixChannelsAndTwelveCounters) {
  namespace cmd = hm2::command;
  hm2::HostMot2Card card;
  CardHost h{card};
  ASSERT_EQ(card.daughtercards(), 1U);
  EXPECT_EQ(card.part<hm2::Sslbp>().channels(), 6U);
  EXPECT_EQ(card.part<hm2::MuxedEncoder>().counters(), 12U);
  h.command(cmd::kStop);
  for (unsigned ch = 0; ch < 6; ++ch) h.write(CardHost::cs(ch), 0);
  EXPECT_EQ(h.command(cmd::kStart | 0x3F), 0x3C);  // no remote on 2..5
  EXPECT_TRUE(card.part<hm2::Sslbp>().channelRunning(0));
  EXPECT_TRUE(card.part<hm2::Sslbp>().channelRunning(1));
  for (unsigned ch = 2; ch < 6; ++ch) EXPECT_FALSE(card.part<hm2::Sslbp>().channelRunning(ch)) << ch;
  EXPECT_EQ(h.read(CardHost::iface(1, 3)), 0U);  // no unit number on channel 3
  EXPECT_EQ(h.read(CardHost::iface(2, 3)), 0U);  // no discovery
  card.part<hm2::MuxedEncoder>().setVelocity(11, -1000, h.now);
  h.wait(10ms);
  EXPECT_NEAR(static_cast<std::int16_t>(h.read(hm2::MuxedEncoder::kCount + 4 * 11) & 0xFFFF), -10, 1);
}

TEST(Card, TheGpioPinoutHasNoSecond7I77) {
  hm2::HostMot2Card::Options o;
  o.pinout = hm2::HostMot2Card::Pinout::SevenI77Gpio;
  o.second = hm2::HostMot2Card::DaughterOptions{};
  EXPECT_THROW(hm2::HostMot2Card{o}, std::invalid_argument);
  o.second.reset();
  hm2::HostMot2Card card(o);
  EXPECT_EQ(card.part<hm2::Sslbp>().channels(), 3U);
  EXPECT_EQ(card.part<hm2::MuxedEncoder>().counters(), 6U);
}

TEST(Card, UnmappedAccessesAreHarmless) {
  hm2::HostMot2Card card;
  CardHost h{card};
  EXPECT_EQ(h.read(0x7000), 0U);
  h.write(0x7000, 0xFFFFFFFF);
  h.write(0x0100, 0);  // the cookie is read only
  EXPECT_EQ(h.read(0x0100), 0x55AACAFEU);
  EXPECT_EQ(h.read(0x0802), 0U);  // just past the IDROM (mesaflash reads there)
  EXPECT_EQ(card.unmappedWrites(), 2U);
}

TEST(Watchdog, BitesAfterItsTimeoutAndResetsGpio) {
  hm2::HostMot2Card card;
  CardHost h{card};
  EXPECT_EQ(h.read(hm2::Watchdog::kTimer), hm2::Watchdog::kDisarmed);  // power-up: disarmed
  h.write(hm2::IoPort::kDdr, 0x1);
  h.write(hm2::IoPort::kData, 0x1);
  EXPECT_TRUE(card.part<hm2::IoPort>().pin(0, 0));
  h.write(hm2::Watchdog::kTimer, 499999);  // LinuxCNC's 5 ms at 100 MHz
  for (int i = 0; i < 20; ++i) {
    h.wait(1ms);
    h.write(hm2::Watchdog::kReset, 0x5A000000);  // pet
  }
  EXPECT_EQ(h.read(hm2::Watchdog::kStatus), 0U);
  h.wait(4900us);
  EXPECT_EQ(h.read(hm2::Watchdog::kStatus), 0U);
  h.wait(200us);
  EXPECT_EQ(h.read(hm2::Watchdog::kStatus), 1U);
  EXPECT_EQ(card.part<hm2::IoPort>().ddr(0), 0U);
  // A pet with the wrong key does not help; clearing the status and
  // rewriting the timer re-arms.
  h.write(hm2::Watchdog::kStatus, 0);
  h.write(hm2::Watchdog::kTimer, 499999);
  h.write(hm2::Watchdog::kReset, 0x12000000);
  h.wait(5100us);
  EXPECT_EQ(h.read(hm2::Watchdog::kStatus), 1U);
  // hm2_eth's unload: timer = 1 bites at once.
  h.write(hm2::Watchdog::kStatus, 0);
  h.write(hm2::Watchdog::kTimer, 1);
  h.wait(1us);
  EXPECT_EQ(h.read(hm2::Watchdog::kStatus), 1U);
}

// watchdog.vhd bites on a rising edge of the timer's bit 31: a write of a
// value with bit 31 set to a running watchdog is such an edge. To one that
// is not running it only disarms.
TEST(Watchdog, WritingBit31WhileItRunsBitesIt) {
  hm2::HostMot2Card card;
  CardHost h{card};
  h.write(hm2::IoPort::kDdr, 0x1);
  h.write(hm2::Watchdog::kTimer, hm2::Watchdog::kDisarmed);  // not running: disarmed, no bite
  EXPECT_EQ(h.read(hm2::Watchdog::kStatus), 0U);
  h.write(hm2::Watchdog::kTimer, 499999);
  h.wait(1ms);
  EXPECT_EQ(h.read(hm2::Watchdog::kStatus), 0U);
  h.write(hm2::Watchdog::kTimer, hm2::Watchdog::kDisarmed);  // running: bit 31 rises
  EXPECT_EQ(h.read(hm2::Watchdog::kStatus), 1U);
  EXPECT_EQ(card.part<hm2::IoPort>().ddr(0), 0U);  // GPIO released
  EXPECT_EQ(h.read(hm2::Watchdog::kTimer), hm2::Watchdog::kDisarmed);  // and it stays stopped
  h.write(hm2::Watchdog::kStatus, 0);
  h.wait(10ms);
  EXPECT_EQ(h.read(hm2::Watchdog::kStatus), 0U);
}

// A pet loads the timer with the value last written to it (wdtime), also
// after it bit: the timer runs again, and bites again unless petted.
TEST(Watchdog, APetAfterABiteRunsTheTimerAgain) {
  hm2::HostMot2Card card;
  CardHost h{card};
  h.write(hm2::Watchdog::kTimer, 99999);  // 1 ms
  h.wait(2ms);
  ASSERT_EQ(h.read(hm2::Watchdog::kStatus), 1U);
  EXPECT_EQ(h.read(hm2::Watchdog::kTimer), 0xFFFFFFFFU);
  h.write(hm2::Watchdog::kStatus, 0);
  h.write(hm2::Watchdog::kReset, 0x5A000000);
  const auto t = h.read(hm2::Watchdog::kTimer);
  EXPECT_LT(t, 99999U);
  EXPECT_GT(t, 99000U);
  h.wait(2ms);
  EXPECT_EQ(h.read(hm2::Watchdog::kStatus), 1U);
  // Disarmed at power-up, a pet does nothing.
  hm2::HostMot2Card fresh;
  CardHost f{fresh};
  f.write(hm2::Watchdog::kReset, 0x5A000000);
  f.wait(1s);
  EXPECT_EQ(f.read(hm2::Watchdog::kStatus), 0U);
  EXPECT_EQ(f.read(hm2::Watchdog::kTimer), hm2::Watchdog::kDisarmed);
}

TEST(Watchdog, LongTimesDoNotOverflow) {
  // 185 s at 100 MHz is more than 2^64 nanosecond-cycles.
  hm2::HostMot2Card card;
  CardHost h{card};
  h.write(hm2::Watchdog::kTimer, 499'999'999);  // 5 s
  h.wait(185s);
  EXPECT_EQ(h.read(hm2::Watchdog::kStatus), 1U);
  const auto before = h.read(hm2::MuxedEncoder::kTimestamp);
  h.wait(200s);
  const auto after = h.read(hm2::MuxedEncoder::kTimestamp);
  // 200 s (and the 1 us the read takes) of the 50 MHz timestamp counter, modulo 2^16.
  EXPECT_EQ(static_cast<std::uint16_t>(after - before), static_cast<std::uint16_t>((200ULL * 50'000'000ULL + 50) & 0xFFFF));
}

// The power-up mux divisor is qcounteratesk.vhd's round(ClockLow / 8 MHz) - 2:
// 11 at 100 MHz (12.5 rounds away from zero), a mux tick every 130 ns, each
// counter sampling every 260 ns.
TEST(MuxedEncoder, PowerUpDivisorIsTheFirmwares) {
  hm2::HostMot2Card card;
  CardHost h{card};
  EXPECT_EQ(h.read(hm2::MuxedEncoder::kRate), 11U);
  EXPECT_EQ(card.part<hm2::MuxedEncoder>().samplePeriod(), SimTime{260});
  h.write(hm2::MuxedEncoder::kRate, 10);  // what LinuxCNC writes for its 8 MHz default
  EXPECT_EQ(card.part<hm2::MuxedEncoder>().samplePeriod(), SimTime{240});
  hm2::MuxedEncoder at50(6, 50'000'000);  // round(6.25) - 2
  EXPECT_EQ(at50.samplePeriod(), SimTime{2 * 6 * 20});
  hm2::MuxedEncoder at33(6, 33'333'333);  // round(4.17) - 2
  EXPECT_EQ(at33.samplePeriod(), SimTime{static_cast<std::int64_t>(2 * 4 * 1e9 / 33'333'333)});
}

TEST(MuxedEncoder, ExactUpTo2MHzAndLosingCountsAbove) {
  for (double rate : {1000.0, 250e3, 1e6, 2e6, 3e6, 6e6}) {
    hm2::HostMot2Card card;
    CardHost h{card};
    h.write(hm2::MuxedEncoder::kRate, 10);  // LinuxCNC's rate: 8.33 MHz mux ticks, exact to 2.08 MHz
    h.write(static_cast<std::uint16_t>(hm2::MuxedEncoder::kControl), 0);  // 3-tick filter
    card.part<hm2::MuxedEncoder>().setVelocity(0, rate, h.now);
    card.part<hm2::MuxedEncoder>().setVelocity(1, -rate, h.now);
    const SimTime span = 1ms;
    h.wait(span);
    const auto expected = static_cast<std::int64_t>(rate * 1e-3);
    const auto got0 = static_cast<std::int16_t>(h.read(hm2::MuxedEncoder::kCount) & 0xFFFF);
    const auto got1 = static_cast<std::int16_t>(h.read(hm2::MuxedEncoder::kCount + 4) & 0xFFFF);
    if (rate <= 2e6) {
      // Each register access takes 1 us of simulated time.
      EXPECT_NEAR(got0, static_cast<double>(expected) + rate * 1e-6, 1) << rate;
      EXPECT_NEAR(got1, -static_cast<double>(expected) - rate * 2e-6, 1) << rate;
    } else {
      EXPECT_LT(std::abs(got0), expected * 9 / 10) << rate << ": counts must be lost";
    }
  }
}

TEST(MuxedEncoder, IndexLatchesJustOnceAndTimestamps) {
  hm2::HostMot2Card card;
  CardHost h{card};
  auto& enc = card.part<hm2::MuxedEncoder>();
  enc.setIndexPeriod(2, 1000);
  h.write(hm2::MuxedEncoder::kTimestampDiv, 48);  // 2 MHz timestamps
  // LinuxCNC's index-enable: latch on index + just once (+ filter).
  h.write(hm2::MuxedEncoder::kControl + 8, (1U << 11) | (1U << 6) | (1U << 4));
  enc.setVelocity(2, 100000, h.now);  // 100 k counts/s: index every 10 ms
  h.wait(5ms);
  EXPECT_TRUE(h.read(hm2::MuxedEncoder::kControl + 8) & (1U << 4));  // not yet
  h.wait(6ms);
  const auto ccr = h.read(hm2::MuxedEncoder::kControl + 8);
  EXPECT_FALSE(ccr & (1U << 4));  // cleared itself
  EXPECT_FALSE(ccr & (1U << 6));
  EXPECT_EQ(ccr >> 16, 1000U);     // the count at the index
  const auto count = h.read(hm2::MuxedEncoder::kCount + 8);
  EXPECT_NEAR(count & 0xFFFF, 1100, 2);
  // The count's timestamp is the timestamp counter at the last count.
  const auto ts = h.read(hm2::MuxedEncoder::kTimestamp);
  EXPECT_LE(static_cast<std::uint16_t>(ts - (count >> 16)), 30U);
  // Any write clears the count.
  h.write(hm2::MuxedEncoder::kCount + 8, 0);
  EXPECT_LE(h.read(hm2::MuxedEncoder::kCount + 8) & 0xFFFF, 1U);
}

// Registers in the whole 16-bit address space on which two cards differ, as
// reads at `at` give them (the first few are reported when `report`).
unsigned registerDifferences(hm2::HostMot2Card& card, hm2::HostMot2Card& fresh, SimTime at, bool report) {
  unsigned differences = 0;
  for (unsigned a = 0; a < 0x10000; a += 4) {
    const auto address = static_cast<std::uint16_t>(a);
    const auto got = card.read32(address, at);
    const auto want = fresh.read32(address, at);
    if (got != want && ++differences <= 10 && report)
      ADD_FAILURE() << std::hex << "register 0x" << a << " reads 0x" << got << ", a fresh card 0x" << want;
  }
  return differences;
}

TEST(Card, PowerCycleLeavesEveryRegisterAsAFreshCardHasIt) {
  namespace cmd = hm2::command;
  hm2::HostMot2Card card;
  CardHost h{card};
  auto& io = card.daughtercard(0).fieldIo;
  auto& analog = card.daughtercard(0).analog;

  // Muxed encoders: 1000 counts on encoder 0 (ending on quadrature state 0,
  // where a fresh card's encoder is), CCR, timestamp divisor and mux rate.
  card.part<hm2::MuxedEncoder>().setVelocity(0, 1000, h.now);
  h.wait(1s);
  card.part<hm2::MuxedEncoder>().setVelocity(0, 0, h.now);
  h.write(hm2::MuxedEncoder::kControl + 4, 0x0C30);
  h.write(hm2::MuxedEncoder::kTimestampDiv, 48);
  h.write(hm2::MuxedEncoder::kRate, 20);
  ASSERT_EQ(h.read(hm2::MuxedEncoder::kCount) & 0xFFFF, 1000U);
  // The watchdog bites (it releases the GPIO), then every GPIO register is set.
  h.write(hm2::Watchdog::kTimer, 1000);
  h.wait(1ms);
  ASSERT_EQ(h.read(hm2::Watchdog::kStatus), 1U);
  for (std::uint16_t reg = hm2::IoPort::kData; reg <= hm2::IoPort::kOutputInvert; reg += 0x100)
    for (std::uint16_t port = 0; port < 2; ++port)
      h.write(static_cast<std::uint16_t>(reg + 4 * port), 0x1A5A5U >> port);
  h.write(hm2::Led::kLeds, 0xF0000000U);
  ASSERT_NE(card.part<hm2::Led>().leds(), 0U);

  // The 7I77 in setup mode: working watchdog times changed, and the field
  // I/O processor's NV one (the manual's NVWATCHDOGTIME) set to 100 ms.
  h.command(cmd::kStop);
  h.write(CardHost::cs(0), 0);
  h.write(CardHost::cs(1), 0);
  ASSERT_EQ(h.command(cmd::kSetupStart | 0x03), 0);
  h.remote(0, 0x65, io.address(io.standard(remote::Standard::WatchdogTime)), 20);
  h.remote(0, lbp::local_write::kNonVolatile, 0, lbp::nonvolatile::kEeprom);
  h.remote(0, 0x65, io.address(io.standard(remote::Standard::NvWatchdogTimeout)), 100);
  h.remote(0, lbp::local_write::kNonVolatile, 0, 0);
  h.remote(1, 0x65, analog.address(analog.standard(remote::Standard::WatchdogTime)), 30);
  ASSERT_EQ(io.watchdogTimeMs(), 20);
  ASSERT_EQ(analog.watchdogTimeMs(), 30);
  // SSLBP: a normal run, then STOP ALL, which clears all of interface 0,
  // byte 2 (inputs 16..23) too (SSLBP 43: 0x00FF0000 with inputs 16..23 on,
  // 0 100 us after STOP ALL); a changed baud rate in the local RAM; channel 1
  // chattering and a START of the empty channel 2 still running.
  for (unsigned i = 16; i < 24; ++i) io.setInputVoltage(i, 24.0);
  h.command(cmd::kStop);
  h.write(CardHost::cs(0), 0);  // software mode 0 (setup mode left LBP commands there)
  h.write(CardHost::cs(1), 0);
  ASSERT_EQ(h.command(cmd::kStart | 0x03), 0);
  ASSERT_EQ(h.command(cmd::kDoit | 0x03), 0);
  ASSERT_EQ(h.read(CardHost::iface(0, 0)), 0x00FF0000U);
  h.command(cmd::kStop);
  h.wait(100us);
  ASSERT_EQ(h.read(CardHost::iface(0, 0)), 0U);
  const std::uint16_t baud0 = hm2::local::kChannelBlock + hm2::local::kBaudOffset;
  h.write(hm2::Sslbp::kData, 0x42);
  h.command(cmd::kWrite | cmd::kRequest | baud0);
  ASSERT_EQ(h.command(cmd::kStart | 0x02), 0);
  h.write(hm2::Sslbp::kCommand, cmd::kStart | 0x04);
  h.wait(1ms);

  hm2::HostMot2Card fresh;
  ASSERT_GT(registerDifferences(card, fresh, h.now, false), 20U);  // the test has something to find
  ASSERT_NE(h.read(hm2::Sslbp::kCommand), 0U);
  card.powerCycle(h.now);
  EXPECT_EQ(registerDifferences(card, fresh, h.now, true), 0U);
  EXPECT_EQ(card.part<hm2::Led>().leds(), 0U);  // write only: not seen by reads
  // The 7I77 booted: working values from the EEPROM (manual: NON-VOLATILE
  // FIELD I/O PARAMETERS), and the power-up watchdog fault.
  EXPECT_EQ(io.watchdogTimeMs(), 100);
  EXPECT_EQ(analog.watchdogTimeMs(), 50);
  EXPECT_EQ(io.faults(), remote::fault::kWatchdog);
  EXPECT_EQ(analog.faults(), remote::fault::kWatchdog);
  // And the card works as a fresh one: RAM at power-up values, the remotes
  // still on their channels.
  EXPECT_EQ(h.command(cmd::kRequest | baud0), 2500000 & 0xFF);
  h.write(CardHost::cs(0), 0);
  h.write(CardHost::cs(1), 0);
  EXPECT_EQ(h.command(cmd::kStart | 0x03), 0);
  EXPECT_EQ(h.command(cmd::kDoit | 0x03), 0);
  EXPECT_EQ(io.faults(), 0);
}

TEST(Card, PowerCycleLeavesAProcessorWithoutSupplyOff) {
  hm2::HostMot2Card::Options o;
  o.first.fieldIo.vinFromField = false;  // W1 right: VIN from TB2
  o.first.fieldIo.vin = 0;
  hm2::HostMot2Card card(o);
  ASSERT_FALSE(card.daughtercard(0).fieldIo.powered());
  card.powerCycle(SimTime{1ms});
  EXPECT_FALSE(card.daughtercard(0).fieldIo.powered());
  EXPECT_TRUE(card.daughtercard(0).analog.powered());
}

TEST(Card, CountsUnmappedAndReadOnlyAccessesAndKeepsTheLastFew) {
  hm2::HostMot2Card card;
  CardHost h{card};
  std::vector<hm2::AccessEvent> seen;
  auto record = [](void* context, const hm2::AccessEvent& e) {
    static_cast<std::vector<hm2::AccessEvent>*>(context)->push_back(e);
  };
  card.setAccessObserver(record, &seen);
  // Accesses something takes are not counted.
  h.read(0x0100);
  h.read(hm2::IoPort::kData);
  h.write(hm2::IoPort::kDdr, 1);
  h.write(hm2::Led::kLeds, 0);
  h.write(hm2::Sslbp::kData, 0);
  EXPECT_TRUE(seen.empty());

  h.write(0x1234, 0x5A04);  // past IOPort's two ports: nothing decodes it
  const SimTime first = h.now;
  h.read(0x7000);
  h.write(0x0100, 0);                           // the cookie
  h.write(0x0404, 1);                           // the IDROM
  h.write(hm2::MuxedEncoder::kTimestamp, 5);    // the free-running timestamp counter
  h.read(0x0802);                               // just past the IDROM
  for (std::uint32_t i = 0; i < 5; ++i) h.write(static_cast<std::uint16_t>(0xF000 + 4 * i), i);
  const auto& c = card.accessCounters();
  EXPECT_EQ(c.unmappedReads, 2U);
  EXPECT_EQ(c.unmappedWrites, 6U);
  EXPECT_EQ(c.readOnlyWrites, 3U);
  EXPECT_EQ(c.ignoredCommands, 0U);
  EXPECT_EQ(c.lostCommands, 0U);
  EXPECT_EQ(card.unmappedWrites(), 9U);  // the sum of every kind

  // The observer saw all eleven, in order, as they happened.
  ASSERT_EQ(seen.size(), 11U);
  EXPECT_EQ(seen[0].address, 0x1234);
  EXPECT_EQ(seen[0].value, 0x5A04U);
  EXPECT_EQ(seen[0].kind, hm2::AccessKind::UnmappedWrite);
  EXPECT_EQ(seen[0].at, first);
  EXPECT_EQ(seen[1].kind, hm2::AccessKind::UnmappedRead);
  EXPECT_EQ(seen[2].kind, hm2::AccessKind::ReadOnlyWrite);
  EXPECT_EQ(seen[4].address, hm2::MuxedEncoder::kTimestamp);
  EXPECT_EQ(hm2::accessKindName(seen[4].kind), "read_only_write");
  // The last eight are kept, oldest first.
  const auto recent = card.recentAccesses();
  ASSERT_EQ(recent.size, hm2::RecentAccesses::kCapacity);
  for (std::size_t i = 0; i < recent.size; ++i) {
    EXPECT_EQ(recent.events[i].address, seen[3 + i].address) << i;
    EXPECT_EQ(recent.events[i].kind, seen[3 + i].kind) << i;
    EXPECT_EQ(recent.events[i].at, seen[3 + i].at) << i;
  }
  EXPECT_EQ(recent.events[7].address, 0xF010);
  EXPECT_EQ(recent.events[7].value, 4U);
  // An unaligned address is kept as the host gave it.
  h.write(0x7002, 9);
  EXPECT_EQ(card.recentAccesses().events[7].address, 0x7002);
  // Removing the observer.
  card.setAccessObserver(nullptr, nullptr);
  h.read(0x7000);
  EXPECT_EQ(seen.size(), 12U);
  EXPECT_EQ(card.accessCounters().unmappedReads, 3U);
}

}  // namespace
