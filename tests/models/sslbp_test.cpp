// SPDX-License-Identifier: MIT
// The SSLBP register interface exactly as the manual's REFERENCE INFORMATION
// describes it, against a virtual 7I92 carrying a 7I77.
#include <gtest/gtest.h>

#include <bit>
#include <map>
#include <string>

#include "support/card_host.hpp"
#include "lbp/protocol.hpp"
#include "remote/field_io.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace remote = lbpkit::model::remote;
namespace lbp = lbpkit::model::lbp;

namespace {

using namespace std::chrono_literals;

using namespace testing_hm2;
namespace cmd = hm2::command;
namespace cs = hm2::cs;
using hm2::Sslbp;

constexpr unsigned kFieldIo = 0;
constexpr unsigned kAnalog = 1;

std::uint8_t localRead(CardHost& h, std::uint16_t addr) { return h.command(cmd::kRequest | addr); }

// The card the SSLBP 43 comparison used (tools/sslbp-compare): 3 SSerial channels, one 7I77 and
// GPIO on the second connector. The default card runs the two-7I77 firmware, 6 channels.
hm2::HostMot2Card::Options threeChannels(hm2::HostMot2Card::Options o = {}) {
  o.pinout = hm2::HostMot2Card::Pinout::SevenI77Gpio;
  return o;
}

TEST(Sslbp, LocalParameters) {
  hm2::HostMot2Card card;
  CardHost h{card};
  EXPECT_EQ(localRead(h, hm2::local::kInterfaceType), 0x12);
  EXPECT_EQ(localRead(h, hm2::local::kInterfaceWidth), 8);
  EXPECT_EQ(localRead(h, hm2::local::kMajorRev), Sslbp::kMajorRevision);
  EXPECT_EQ(localRead(h, hm2::local::kMinorRev), Sslbp::kMinorRevision);
  // The manual calls 4 and 5 GP_INPUTS/GP_OUTPUTS (0); the firmware keeps the
  // per-channel block start and stride there, and LinuxCNC and mesaflash use
  // them so (local[4] + channel * local[5] + 42 is a channel's baud rate).
  EXPECT_EQ(localRead(h, hm2::local::kChannelStart), hm2::local::kChannelBlock);
  EXPECT_EQ(localRead(h, hm2::local::kChannelStride), hm2::local::kChannelBlockStride);
  EXPECT_EQ(localRead(h, hm2::local::kProcessorType), 0xD8);
  // Copied from the hardware channel count: 6 with two 7I77 connectors.
  EXPECT_EQ(localRead(h, hm2::local::kChannels), card.part<hm2::Sslbp>().channels());
  EXPECT_EQ(card.part<hm2::Sslbp>().channels(), 6U);
  // Local write then read back (the channel 0 baud rate, LSB).
  const std::uint16_t baud0 = hm2::local::kChannelBlock + hm2::local::kBaudOffset;
  EXPECT_EQ(localRead(h, baud0), 2500000 & 0xFF);
  h.write(Sslbp::kData, 0x42);
  h.command(cmd::kWrite | cmd::kRequest | baud0);
  EXPECT_EQ(localRead(h, baud0), 0x42);
}

TEST(Sslbp, StopAllResetsAndDataReadsAA) {
  hm2::HostMot2Card card;
  CardHost h{card};
  EXPECT_EQ(h.command(cmd::kStop), 0xAA);
  EXPECT_EQ(h.read(CardHost::cs(0)), 0x0000C100U);  // not ready, no ID, remote fault; state 0
}

// NORMAL MODE OPERATION steps 1..11 at 1 kHz for 10 simulated seconds.
TEST(Sslbp, NormalModeOperationAt1kHzFor10Seconds) {
  hm2::HostMot2Card card;
  CardHost h{card};
  auto& io = card.daughtercard(0).fieldIo;
  auto& analog = card.daughtercard(0).analog;
  // 1. STOP ALL.  2./3. START channels 0 and 1, wait.  4. DATA: all started.
  h.command(cmd::kStop);
  h.write(CardHost::cs(kFieldIo), 0);  // remote mode 0 in the CS top byte
  h.write(CardHost::cs(kAnalog), 0);
  h.write(Sslbp::kCommand, cmd::kStart | 0x03);
  const SimTime startTime = h.waitCommand();
  ASSERT_GT(startTime.count(), 0);
  EXPECT_GT(startTime, 400us);  // the silent start timeout, then the setup exchange
  EXPECT_EQ(h.read(Sslbp::kData) & 0x03, 0U);
  // 5. Unit number, name, table pointers: only before the first DOIT.
  EXPECT_EQ(h.read(CardHost::iface(0, kFieldIo)), io.unitNumber());
  EXPECT_EQ(h.read(CardHost::iface(0, kAnalog)), analog.unitNumber());
  EXPECT_EQ(h.read(CardHost::iface(1, kFieldIo)), 0x37374937U);  // "7I77", LSB first
  EXPECT_NE(h.read(CardHost::iface(2, kFieldIo)) & 0xFFFF, 0U);
  // After START: status OK, chattering (COM_STATE 0x3A/0x3B), no faults.
  const auto csAfterStart = h.read(CardHost::cs(kFieldIo));
  EXPECT_EQ(csAfterStart & 0xFFFF, 0U) << std::hex << csAfterStart;
  EXPECT_EQ(csAfterStart >> 24, 0U);
  // Chatter feeds the remote watchdogs while the host is busy elsewhere.
  h.wait(200ms);
  EXPECT_EQ(io.faults(), 0);

  std::uint32_t lastInputs = 0;
  int checked = 0;
  for (int cycle = 0; cycle < 10000; ++cycle) {
    // 6. COMMAND clear?  7. DATA: previous DOIT ok?
    ASSERT_EQ(h.read(Sslbp::kCommand), 0U) << "cycle " << cycle;
    if (cycle > 0) {
      ASSERT_EQ(h.read(Sslbp::kData), 0U) << "cycle " << cycle;
      // 8. Inputs.
      lastInputs = h.read(CardHost::iface(0, kFieldIo));
      const auto csr = h.read(CardHost::cs(kFieldIo));
      ASSERT_EQ(csr & 0xFFFF, 0U) << std::hex << csr;
      ASSERT_EQ(csr >> 24, 0U);
      if (cycle % 1000 == 1) {
        EXPECT_EQ(lastInputs, io.inputs()) << "cycle " << cycle;
        ++checked;
      }
    }
    // The world changes an input now and then.
    if (cycle % 1000 == 0) io.setInputVoltage(static_cast<unsigned>(cycle / 1000), 24.0);
    // 9. Outputs: a walking bit, and an analog ramp.
    const std::uint32_t outputs = 1U << (cycle % 16);
    h.write(CardHost::iface(0, kFieldIo), outputs);
    const auto code = static_cast<std::int32_t>((cycle % 8192) - 4096);
    std::array<std::uint8_t, 12> ao{};
    for (unsigned ch = 0; ch < 6; ++ch) lbp::packBits(ao, ch * 13, 13, static_cast<std::uint32_t>(code) & 0x1FFF);
    lbp::packBits(ao, 78, 1, 1);
    lbp::packBits(ao, 79, 1, static_cast<std::uint64_t>(cycle % 2));
    for (unsigned r = 0; r < 3; ++r)
      h.write(CardHost::iface(r, kAnalog), std::uint32_t{ao[4 * r]} | (std::uint32_t{ao[4 * r + 1]} << 8) |
                                               (std::uint32_t{ao[4 * r + 2]} << 16) |
                                               (std::uint32_t{ao[4 * r + 3]} << 24));
    // 10. DOIT.
    h.write(Sslbp::kCommand, cmd::kDoit | 0x03);
    // The manual: at most 100 us from DOIT to COMMAND clear. The very first
    // DOIT is picked up by the chatter loop at its next reply: a bit longer.
    const SimTime doit = h.waitCommand(1ms);
    ASSERT_GT(doit.count(), 0);
    ASSERT_LT(doit, cycle == 0 ? 200us : 100us) << "cycle " << cycle;
    ASSERT_EQ(io.outputs(), outputs) << "cycle " << cycle;
    ASSERT_EQ(analog.dacCode(3), code);
    ASSERT_EQ(analog.enable(5), cycle % 2 == 1);
    // 11. Wait for the next cycle.
    h.now = SimTime{std::chrono::milliseconds(cycle + 1)} + 200ms + startTime;
  }
  EXPECT_EQ(checked, 10);
  EXPECT_EQ(lastInputs, 0x3FFU);  // inputs 0..9 were switched on
  EXPECT_EQ(io.faults(), 0);
  EXPECT_EQ(analog.faults(), 0);
}

// The manual's SETUP MODE remote read and write examples, and NVWATCHDOGTIME.
TEST(Sslbp, SetupModeRemoteReadAndWrite) {
  hm2::HostMot2Card card;
  CardHost h{card};
  auto& io = card.daughtercard(0).fieldIo;
  h.command(cmd::kStop);
  h.write(CardHost::cs(kFieldIo), 0);
  ASSERT_EQ(h.command(cmd::kSetupStart | 0x01) & 0x01, 0);
  EXPECT_EQ(h.read(CardHost::cs(kFieldIo)) & 0xFF00U, 0U);  // status OK
  // Remote word read (0x45) of the watchdog time.
  const auto wd = io.address(io.standard(remote::Standard::WatchdogTime));
  EXPECT_EQ(h.remote(kFieldIo, 0x45, wd) & 0xFFFF, 50U);
  // Remote word write (0x65), then read back.
  h.remote(kFieldIo, 0x65, wd, 20);
  EXPECT_EQ(io.watchdogTimeMs(), 20);
  EXPECT_EQ(h.remote(kFieldIo, 0x45, wd) & 0xFFFF, 20U);
  // NVWATCHDOGTIME the way LinuxCNC writes NV parameters: NV access on
  // (local write 0xEC = 1), sized write, NV access off.
  const auto nvwd = io.address(io.standard(remote::Standard::NvWatchdogTimeout));
  h.remote(kFieldIo, lbp::local_write::kNonVolatile, 0, lbp::nonvolatile::kEeprom);
  h.remote(kFieldIo, 0x65, nvwd, 100);
  h.remote(kFieldIo, lbp::local_write::kNonVolatile, 0, 0);
  EXPECT_EQ(h.remote(kFieldIo, 0x45, nvwd) & 0xFFFF, 100U);
  EXPECT_EQ(io.watchdogTimeMs(), 20);  // working value until a power cycle
  io.setFieldVoltage(0, h.now);
  io.setFieldVoltage(24, h.now);
  EXPECT_EQ(io.watchdogTimeMs(), 100);
  // The byte read LinuxCNC uses (0x4C: read 1 byte, auto-increment, address).
  EXPECT_EQ(h.remote(kFieldIo, 0x4C, 0x0400) & 0xFF, lbp::kProcessDataRecord);
}

// The DISCOVERY SEQUENCE through the registers, for both remotes.
TEST(Sslbp, DiscoverySequenceThroughTheRegisters) {
  hm2::HostMot2Card card;
  CardHost h{card};
  for (std::uint8_t mode : {std::uint8_t{0}, std::uint8_t{3}}) {
    h.command(cmd::kStop);
    h.write(CardHost::cs(kFieldIo), static_cast<std::uint32_t>(mode) << 24);
    h.write(CardHost::cs(kAnalog), 0);
    ASSERT_EQ(h.command(cmd::kSetupStart | 0x03) & 0x03, 0);
    for (unsigned ch : {kFieldIo, kAnalog}) {
      const auto ptocp = static_cast<std::uint16_t>(h.read(CardHost::iface(2, ch)) & 0xFFFF);
      ASSERT_NE(ptocp, 0);
      std::vector<std::uint16_t> ptoc;
      for (std::uint16_t p = ptocp;; p += 2) {
        const auto e = static_cast<std::uint16_t>(h.remote(ch, 0x45, p));
        if (e == 0) break;
        ptoc.push_back(e);
      }
      unsigned inBits = 0, outBits = 0;
      std::map<std::string, int> names;
      for (auto rec : ptoc) {
        const auto type = static_cast<std::uint8_t>(h.remote(ch, 0x44, rec));
        if (type == lbp::kModeRecord) continue;
        ASSERT_EQ(type, lbp::kProcessDataRecord);
        const auto bits = static_cast<std::uint8_t>(h.remote(ch, 0x44, rec + 1));
        const auto dir = static_cast<std::uint8_t>(h.remote(ch, 0x44, rec + 3));
        (void)std::bit_cast<float>(static_cast<std::uint32_t>(h.remote(ch, 0x46, rec + 4)));
        std::string unit, name;
        std::uint16_t p = static_cast<std::uint16_t>(rec + 14);
        for (char c; (c = static_cast<char>(h.remote(ch, 0x44, p++))) != 0;) unit.push_back(c);
        for (char c; (c = static_cast<char>(h.remote(ch, 0x44, p++))) != 0;) name.push_back(c);
        names[name] = bits;
        if (dir != 0x80) inBits += bits;
        if (dir != 0x00) outBits += bits;
      }
      if (ch == kFieldIo) {
        EXPECT_EQ(names.at("Input"), 32);
        EXPECT_EQ(names.at("Output"), 16);
        EXPECT_EQ(names.count("Enc1"), mode == 3 ? 1U : 0U);
        EXPECT_EQ(inBits, mode == 3 ? 88U : 32U);
        EXPECT_EQ(outBits, 16U);
      } else {
        EXPECT_EQ(names.at("AnalogOut5"), 13);
        EXPECT_EQ(outBits, 80U);
      }
    }
  }
}

TEST(Sslbp, StoppingDoitsDropsOutputsAndTheFaultShowsAtTheNextStart) {
  hm2::HostMot2Card card;
  CardHost h{card};
  auto& io = card.daughtercard(0).fieldIo;
  auto& analog = card.daughtercard(0).analog;
  h.command(cmd::kStop);
  ASSERT_EQ(h.command(cmd::kStart | 0x03), 0);
  h.write(CardHost::iface(0, kFieldIo), 0xFFFF);
  h.write(CardHost::iface(2, kAnalog), 0xC000);  // both enables
  for (int i = 0; i < 10; ++i) {
    ASSERT_EQ(h.command(cmd::kDoit | 0x03), 0);
    h.wait(1ms);
  }
  EXPECT_EQ(io.outputs(), 0xFFFF);
  EXPECT_TRUE(analog.enable(0));
  h.wait(60ms);  // the host stops: no DOIT, no chatter after the first DOIT
  EXPECT_EQ(io.outputs(), 0);
  EXPECT_FALSE(analog.enable(0));
  EXPECT_EQ(io.faults(), remote::fault::kWatchdog);
  // A DOIT now reports the remote fault in CS byte 3 (and status bit 0).
  EXPECT_EQ(h.command(cmd::kDoit | 0x01), 0);
  const auto csr = h.read(CardHost::cs(kFieldIo));
  EXPECT_EQ(csr >> 24, remote::fault::kWatchdog);
  EXPECT_TRUE(csr & (cs::kStatusRemoteFault << 8));
  EXPECT_TRUE(csr & cs::kRemoteFault);
  // Recovery: stop and start the channel; START clears the fault. CS byte 3
  // keeps the old fault byte until the first DOIT's reply replaces it (a
  // START that reads no fault leaves it: SSLBP 43, CS 0x203B0000 after a
  // LowVoltageFault, see HeldRemoteFaultNeverRaisesTooManyErrorsAsFirmware43).
  h.command(cmd::kStop | 0x03);
  ASSERT_EQ(h.command(cmd::kStart | 0x03), 0);
  EXPECT_EQ(io.faults(), 0);
  EXPECT_EQ(h.read(CardHost::cs(kFieldIo)) >> 24, remote::fault::kWatchdog);
  ASSERT_EQ(h.command(cmd::kDoit | 0x03), 0);
  EXPECT_EQ(h.read(CardHost::cs(kFieldIo)) >> 24, 0U);
  EXPECT_EQ(io.outputs(), 0xFFFF);
}

TEST(Sslbp, AFaultThatDoesNotClearFailsTheStart) {
  hm2::HostMot2Card::Options o;
  o.first.fieldIo.vinFromField = false;  // W1 right: separate VIN
  o.first.fieldIo.vin = 24;
  hm2::HostMot2Card card(o);
  CardHost h{card};
  card.daughtercard(0).fieldIo.setFieldVoltage(2.0, h.now);  // field supply lost
  h.command(cmd::kStop);
  EXPECT_EQ(h.command(cmd::kStart | 0x01), 0x01);  // channel 0 failed
  const auto csr = h.read(CardHost::cs(kFieldIo));
  EXPECT_EQ(csr >> 24, remote::fault::kLowVoltage);
  EXPECT_TRUE(csr & cs::kTooManyErrors);
  EXPECT_TRUE(csr & cs::kRemoteFault);
}

TEST(Sslbp, NoRemoteFailsTheStartWithTimeouts) {
  hm2::HostMot2Card card;
  CardHost h{card};
  h.command(cmd::kStop);
  h.write(Sslbp::kCommand, cmd::kStart | 0x04);  // channel 2: TB6, nothing attached
  const SimTime t = h.waitCommand();
  ASSERT_GT(t.count(), 0);
  EXPECT_GT(t, 10ms);  // 21 timeouts of 400 us plus the waits
  EXPECT_EQ(h.read(Sslbp::kData), 0x04U);
  const auto csr = h.read(CardHost::cs(2));
  EXPECT_EQ(csr & 0xFF, cs::kTimeout | cs::kTooManyErrors);
  EXPECT_TRUE(csr & (cs::kStatusNotReady << 8));
  // A DOIT on a channel that did not start: not requested, nothing flagged.
  EXPECT_EQ(h.command(cmd::kDoit | 0x04), 0);
}

TEST(Sslbp, DoitTimingFollowsTheCharactersOnTheWire) {
  // 2.5 MBaud, normal mode: field I/O mode 0 sends BD + 2 + CRC (4 chars)
  // and gets 5 + CRC back; analog 12 out, 2 back.
  {
    hm2::HostMot2Card card;
    CardHost h{card};
    h.accessTime = SimTime{100};
    h.command(cmd::kStop);
    ASSERT_EQ(h.command(cmd::kStart | 0x01), 0);
    h.write(Sslbp::kCommand, cmd::kDoit | 0x01);
    const SimTime first = h.waitCommand();  // the first DOIT waits for a chatter reply
    h.write(Sslbp::kCommand, cmd::kDoit | 0x01);
    const SimTime t = h.waitCommand();
    const SimTime wire = lbp::characterTime(2500000) * 10;  // 4 out + 6 back
    EXPECT_GE(t, wire);
    EXPECT_LT(t, wire + 15us);
    EXPECT_GE(first, t);
    h.write(Sslbp::kCommand, cmd::kDoit | 0x02);  // analog: not started, trivially done
    EXPECT_LT(h.waitCommand(), 10us);
  }
  // 115.2 kBaud: the remote jumpered for setup mode, the channel's baud rate
  // changed through its local parameter, then a setup-mode word read.
  {
    hm2::HostMot2Card::Options o;
    o.first.fieldIo.setupMode = true;
    hm2::HostMot2Card card(o);
    CardHost h{card};
    const std::uint16_t baud0 = hm2::local::kChannelBlock + hm2::local::kBaudOffset;
    for (unsigned i = 0; i < 4; ++i) {
      h.write(Sslbp::kData, (115200U >> (8 * i)) & 0xFF);
      h.command(cmd::kWrite | cmd::kRequest | (baud0 + i));
    }
    h.command(cmd::kStop);  // STOP ALL reloads the baud rates
    EXPECT_EQ(card.part<hm2::Sslbp>().channelBaud(0), 115200U);
    ASSERT_EQ(h.command(cmd::kSetupStart | 0x01), 0);
    auto& io = card.daughtercard(0).fieldIo;
    h.write(CardHost::cs(0), 0x45000000U | io.address(io.standard(remote::Standard::NvBaudRate)));
    h.write(Sslbp::kCommand, cmd::kDoit | 0x01);
    const SimTime t = h.waitCommand();
    const SimTime wire = lbp::characterTime(115200) * 7;  // 45 lo hi CRC, then 2 + CRC
    EXPECT_GE(t, wire);
    EXPECT_LT(t, wire + 20us);
    EXPECT_EQ(h.read(Sslbp::kData), 0U);
    EXPECT_EQ(h.read(CardHost::iface(0, 0)) & 0xFFFF, 9U);  // NVBaudRate: 2.5 MBaud index
  }
}

TEST(Sslbp, CommandWrittenWhileBusyIsLostAndReported) {
  hm2::HostMot2Card card;
  CardHost h{card};
  h.command(cmd::kStop);
  h.write(Sslbp::kCommand, cmd::kStart | 0x01);
  h.write(Sslbp::kCommand, cmd::kDoit | 0x01);  // busy: lost
  EXPECT_EQ(h.read(Sslbp::kCommand), cmd::kDoit | 0x01U);
  ASSERT_GE(h.waitCommand().count(), 0);
  EXPECT_EQ(h.read(Sslbp::kData), 0xFFU);
  EXPECT_EQ(card.part<hm2::Sslbp>().counters().lostCommands, 1U);
  // Writes with bit 31 set are ignored, even while busy.
  h.write(Sslbp::kCommand, cmd::kDoit | 0x01);
  h.write(Sslbp::kCommand, 0x80000000U | cmd::kStart | 0x02);
  ASSERT_GE(h.waitCommand().count(), 0);
  EXPECT_EQ(h.read(Sslbp::kData), 0U);
  // STOP ALL always works, even mid-START.
  h.write(Sslbp::kCommand, cmd::kStart | 0x02);
  h.write(Sslbp::kCommand, cmd::kStop);
  ASSERT_GE(h.waitCommand().count(), 0);
  EXPECT_EQ(h.read(Sslbp::kData), 0xAAU);
  // Unknown commands complete with DATA = 0xFF.
  EXPECT_EQ(h.command(0x0123), 0xFF);
}

TEST(Sslbp, ResetBitHoldsTheProcessorUntilReleased) {
  hm2::HostMot2Card card;
  CardHost h{card};
  h.write(Sslbp::kCommand, cmd::kReset);  // LinuxCNC: 0x4000, then 0x0001
  h.wait(1ms);
  EXPECT_EQ(h.read(Sslbp::kCommand), cmd::kReset);
  h.write(Sslbp::kCommand, 0x0001);
  EXPECT_GE(h.waitCommand().count(), 0);
  EXPECT_NE(localRead(h, hm2::local::kMinorRev), 0xAA);
}

TEST(Sslbp, LinkFaultsShowAsCsBits) {
  hm2::HostMot2Card card;
  CardHost h{card};
  auto& link = card.part<hm2::Sslbp>().link(kFieldIo);
  h.command(cmd::kStop);
  ASSERT_EQ(h.command(cmd::kStart | 0x01), 0);
  ASSERT_EQ(h.command(cmd::kDoit | 0x01), 0);
  // A corrupted reply: CRC error and a timeout, the DOIT fails.
  link.corruptNext(hm2::SerialLink::Direction::FromRemote);
  EXPECT_EQ(h.command(cmd::kDoit | 0x01), 0x01);
  auto csr = h.read(CardHost::cs(kFieldIo));
  EXPECT_EQ(csr & 0xFF, cs::kCrcError | cs::kTimeout);
  EXPECT_TRUE(csr & (cs::kStatusCommunicationError << 8));
  EXPECT_EQ(h.command(cmd::kDoit | 0x01), 0);  // next one is fine
  // An extra character: flagged before the next transmit.
  link.addExtra(hm2::SerialLink::Direction::FromRemote);
  EXPECT_EQ(h.command(cmd::kDoit | 0x01), 0);
  EXPECT_EQ(h.command(cmd::kDoit | 0x01), 0);
  EXPECT_TRUE(h.read(CardHost::cs(kFieldIo)) & cs::kExtraCharacter);
  // A break.
  link.breakNext();
  EXPECT_EQ(h.command(cmd::kDoit | 0x01), 0x01);
  EXPECT_TRUE(h.read(CardHost::cs(kFieldIo)) & cs::kSerialBreak);
  // A cut cable: every DOIT fails; the 21st timeout sets TooManyErrors.
  link.setConnected(false);
  for (int i = 0; i < 25; ++i) EXPECT_EQ(h.command(cmd::kDoit | 0x01), 0x01);
  EXPECT_TRUE(h.read(CardHost::cs(kFieldIo)) & cs::kTooManyErrors);
  // Errors are sticky until the channel is stopped.
  link.setConnected(true);
  h.command(cmd::kStop | 0x01);
  EXPECT_EQ(h.read(CardHost::cs(kFieldIo)) & 0xFF, 0U);
  ASSERT_EQ(h.command(cmd::kStart | 0x01), 0);
  EXPECT_EQ(h.command(cmd::kDoit | 0x01), 0);
}

// The card counts what the SSLBP refuses, each kind on its own (manual:
// COMMAND REGISTER WRITE IGNORE; COMMAND REGISTER, "should not be written
// when non-zero"), and the CS and interface registers of channels the
// instance does not have decode as nothing.
TEST(Sslbp, TheCardCountsRefusedCommandsByKind) {
  hm2::HostMot2Card card;
  CardHost h{card};
  h.command(cmd::kStop);
  h.write(Sslbp::kCommand, cmd::kStart | 0x01);
  h.write(Sslbp::kCommand, 0x80000000U | cmd::kDoit | 0x01);  // ignored
  h.write(Sslbp::kCommand, cmd::kDoit | 0x01);                // busy: lost
  ASSERT_GE(h.waitCommand().count(), 0);
  EXPECT_EQ(h.read(Sslbp::kData), 0xFFU);
  EXPECT_EQ(card.accessCounters().ignoredCommands, 1U);
  EXPECT_EQ(card.accessCounters().lostCommands, 1U);
  EXPECT_EQ(card.part<hm2::Sslbp>().counters().lostCommands, 1U);
  auto recent = card.recentAccesses();
  ASSERT_EQ(recent.size, 2U);
  EXPECT_EQ(recent.events[0].kind, hm2::AccessKind::IgnoredCommand);
  EXPECT_EQ(recent.events[0].value, 0x80000000U | cmd::kDoit | 0x01);
  EXPECT_EQ(recent.events[1].kind, hm2::AccessKind::LostCommand);
  EXPECT_EQ(recent.events[1].address, Sslbp::kCommand);
  EXPECT_EQ(recent.events[1].value, cmd::kDoit | 0x01U);
  // STOP ALL is taken while busy, not lost.
  h.write(Sslbp::kCommand, cmd::kStart | 0x04);
  h.write(Sslbp::kCommand, cmd::kStop);
  ASSERT_GE(h.waitCommand().count(), 0);
  EXPECT_EQ(card.accessCounters().lostCommands, 1U);
  // The registers of a channel the instance lacks are not there.
  const unsigned missing = card.part<hm2::Sslbp>().channels();
  h.write(CardHost::cs(missing - 1), 0);
  EXPECT_EQ(card.accessCounters().unmappedWrites, 0U);
  h.write(CardHost::cs(missing), 0x12345678);
  h.write(CardHost::iface(2, missing), 1);
  EXPECT_EQ(h.read(CardHost::cs(missing)), 0U);
  EXPECT_EQ(card.accessCounters().unmappedWrites, 2U);
  EXPECT_EQ(card.accessCounters().unmappedReads, 1U);
  recent = card.recentAccesses();
  EXPECT_EQ(recent.events[recent.size - 2].address, CardHost::iface(2, missing));
}

// Module::reset(): the SSLBP alone back to its power-up state, links kept.
TEST(Sslbp, ResetIsThePowerUpState) {
  hm2::HostMot2Card card;
  CardHost h{card};
  card.daughtercard(0).fieldIo.setInputVoltage(16, 24.0);
  h.command(cmd::kStop);
  ASSERT_EQ(h.command(cmd::kStart | 0x03), 0);
  ASSERT_EQ(h.command(cmd::kDoit | 0x03), 0);
  ASSERT_EQ((h.read(CardHost::cs(kFieldIo)) >> 16) & 0xFF, 0x42U);  // COM_STATE: normal run
  // Interface 0 byte 2 (inputs 16..23): power-up clears it.
  ASSERT_NE(h.read(CardHost::iface(0, kFieldIo)) & 0x00FF0000U, 0U);
  const std::uint16_t baud1 =
      hm2::local::kChannelBlock + hm2::local::kChannelBlockStride + hm2::local::kBaudOffset;
  h.write(Sslbp::kData, 0x42);
  h.command(cmd::kWrite | cmd::kRequest | baud1);
  ASSERT_EQ(localRead(h, baud1), 0x42);
  card.part<hm2::Sslbp>().reset();
  EXPECT_EQ(h.read(Sslbp::kCommand), 0U);
  EXPECT_EQ(h.read(Sslbp::kData), 0xAAU);
  for (unsigned ch = 0; ch < 3; ++ch) {
    EXPECT_EQ(h.read(CardHost::cs(ch)), 0x0000C100U) << ch;
    for (unsigned n = 0; n < 3; ++n) EXPECT_EQ(h.read(CardHost::iface(n, ch)), 0U) << ch << " " << n;
    EXPECT_FALSE(card.part<hm2::Sslbp>().channelRunning(ch));
  }
  EXPECT_EQ(localRead(h, baud1), 2500000 & 0xFF);
  EXPECT_EQ(card.part<hm2::Sslbp>().channelBaud(1), Sslbp::kDefaultBaud);
  // The remotes are still on their channels.
  ASSERT_EQ(h.command(cmd::kStart | 0x03), 0);
  EXPECT_EQ(h.read(CardHost::iface(1, kFieldIo)), 0x37374937U);  // "7I77", LSB first
}

// --- Mesa's SSLBP 43 as the truth -----------------------------------------------------------
// The values below were read from Mesa's real SSLBP firmware (version 43, 3 channels as on a 7I92
// with one 7I77, 100 MHz) run cycle by cycle in Verilator with lbpkit's own field I/O and analog
// processors on channels 0 and 1 (tools/sslbp-compare; docs/sslbp-vs-firmware.md). The host
// accesses registers every 20 ns and polls COMMAND every 220 ns, as the comparison's host does.

double ms(SimTime t) { return std::chrono::duration<double, std::milli>(t).count(); }
double us(SimTime t) { return std::chrono::duration<double, std::micro>(t).count(); }

SimTime waitPolled(CardHost& h) {
  const SimTime start = h.now;
  while (h.read(Sslbp::kCommand) != 0) {
    if (h.now - start > 10s) return SimTime{-1};
    h.wait(SimTime{200});
  }
  return h.now - start;
}

// The comparison's field I/O processor: VIN from a separate 24 V supply (7I77 W1 right), so that
// dropping field power leaves it running and reporting LowVoltageFault.
hm2::HostMot2Card::Options separateVin() {
  hm2::HostMot2Card::Options o;
  o.first.fieldIo.vinFromField = false;
  o.first.fieldIo.vin = 24;
  return threeChannels(o);
}

// LinuxCNC's stopstart: STOP ALL, software mode 0 in both channels' CS, normal START of both.
void startBoth(CardHost& h) {
  h.command(cmd::kStop);
  h.write(CardHost::cs(kFieldIo), 0);
  h.write(CardHost::cs(kAnalog), 0);
  ASSERT_EQ(h.command(cmd::kStart | 0x03), 0);
}

TEST(Sslbp, LocalParametersMatchFirmware43) {
  // The 3-channel build (one 7I77) and the 6-channel one (two 7I77s, the default card).
  for (const std::uint8_t n : {std::uint8_t{3}, std::uint8_t{6}}) {
    hm2::HostMot2Card card(n == 3 ? threeChannels() : hm2::HostMot2Card::Options{});
    CardHost h{card};
    const std::uint8_t identity[8] = {0x12, 0x08, 0x01, 0x2B, 0x70, 0x32, 0xD8, n};
    for (std::uint16_t a = 0; a < 8; ++a) EXPECT_EQ(localRead(h, a), identity[a]) << "local " << a;
    // I/O above the RAM: the interface clock, 100 000 000 Hz little-endian, and the hardware
    // channel count (which local 7 is copied from).
    const std::uint8_t io[5] = {0x00, 0xE1, 0xF5, 0x05, n};
    for (std::uint16_t a = 0; a < 5; ++a) {
      EXPECT_EQ(localRead(h, static_cast<std::uint16_t>(0x230 + a)), io[a]) << "local 0x" << std::hex << 0x230 + a;
    }
  }
}

TEST(Sslbp, StopAllTakesAsLongAsFirmware43) {
  // The global init sets up every channel's UART: 46.89 us with 3 channels, 92.43 us with 6.
  for (const auto& [options, firmware] : {std::pair{threeChannels(), 46.89}, std::pair{hm2::HostMot2Card::Options{}, 92.43}}) {
    hm2::HostMot2Card card(options);
    CardHost h{card};
    h.accessTime = SimTime{20};
    h.write(Sslbp::kCommand, cmd::kStop);
    const SimTime t = waitPolled(h);
    EXPECT_NEAR(us(t), firmware, 1.5) << "us";
    EXPECT_EQ(h.read(Sslbp::kData), 0xAAU);
  }
}

TEST(Sslbp, NoRemoteSetupStartMatchesFirmware43) {
  hm2::HostMot2Card card(threeChannels());
  CardHost h{card};
  h.accessTime = SimTime{20};
  h.command(cmd::kStop);
  h.write(CardHost::cs(2), 0);
  // Nothing on channel 2: the cookie request 21 times, 2.6 ms apart (the first 1.42 ms after
  // the command), then the 21st timeout: done after 54.62 ms, the channel back at its start
  // timer (COM_STATE 1), status 0xE1, error log 0x88 (timeout, too many errors).
  h.write(Sslbp::kCommand, cmd::kSetupStart | 0x04);
  const SimTime setup = waitPolled(h);
  EXPECT_NEAR(ms(setup), 54.62, 0.05) << "ms";
  EXPECT_EQ(h.read(Sslbp::kData), 0x04U);
  EXPECT_EQ(h.read(CardHost::cs(2)), 0x0001E188U);
  // Normal START next: 2 us timer ticks, cookie requests ~806 us apart, the first one 402 us
  // plus the rest of the 200 us setup tick after the command (firmware: 553 us in our run,
  // 17.07 ms in all); CS 0x0001E188 again.
  h.command(cmd::kStop);
  h.write(CardHost::cs(2), 0);
  h.write(Sslbp::kCommand, cmd::kStart | 0x04);
  const SimTime normal = waitPolled(h);
  EXPECT_GT(ms(normal), 16.85) << "ms";
  EXPECT_LT(ms(normal), 17.25) << "ms";
  EXPECT_EQ(h.read(Sslbp::kData), 0x04U);
  EXPECT_EQ(h.read(CardHost::cs(2)), 0x0001E188U);
}

TEST(Sslbp, BothProcessorsStartAndRunAsWithFirmware43) {
  hm2::HostMot2Card card(threeChannels());
  CardHost h{card};
  h.accessTime = SimTime{20};
  h.command(cmd::kStop);
  h.write(CardHost::cs(kFieldIo), 0);
  h.write(CardHost::cs(kAnalog), 0);
  h.write(Sslbp::kCommand, cmd::kSetupStart | 0x03);
  const SimTime setup = waitPolled(h);
  EXPECT_NEAR(ms(setup), 1.704, 0.05) << "ms";  // firmware 1.704 ms
  EXPECT_EQ(h.read(Sslbp::kData), 0U);
  const std::uint32_t expected[2][4] = {{0x00400000, 0x12000AEE, 0x37374937, 0x0666065C},
                                        {0x00400000, 0x11000AEE, 0x37374937, 0x05DC05C6}};
  for (unsigned ch = 0; ch < 2; ++ch) {
    EXPECT_EQ(h.read(CardHost::cs(ch)), expected[ch][0]);
    for (unsigned n = 0; n < 3; ++n) EXPECT_EQ(h.read(CardHost::iface(n, ch)), expected[ch][n + 1]);
  }
  // A LinuxCNC-style discovery read (one byte per DOIT): firmware 30.7 us each.
  h.write(CardHost::cs(kFieldIo), 0x4C000000U | 0x0694U);
  h.write(Sslbp::kCommand, cmd::kDoit | 0x01);
  const SimTime read = waitPolled(h);
  EXPECT_NEAR(us(read), 30.7, 2.0) << "us";
  EXPECT_EQ(h.read(Sslbp::kData), 0U);
  h.command(cmd::kStop);
  h.write(CardHost::cs(kFieldIo), 0);
  h.write(CardHost::cs(kAnalog), 0);
  h.write(Sslbp::kCommand, cmd::kStart | 0x03);
  ASSERT_GE(waitPolled(h).count(), 0);
  EXPECT_EQ(h.read(Sslbp::kData), 0U);
  // 1000 process data DOITs of both channels: firmware 63.87 us on average, none failed,
  // CS 0x00420000 (COM_STATE 0x42: normal run).
  SimTime total{};
  for (int k = 0; k < 1000; ++k) {
    h.write(CardHost::iface(0, kFieldIo), static_cast<std::uint32_t>(k * 7) & 0xFFFF);
    h.write(CardHost::iface(0, kAnalog), static_cast<std::uint32_t>(k * 13) & 0xFFFF);
    h.write(Sslbp::kCommand, cmd::kDoit | 0x03);
    const SimTime t = waitPolled(h);
    ASSERT_GE(t.count(), 0);
    if (k > 0) total += t;
    ASSERT_EQ(h.read(Sslbp::kData), 0U) << "DOIT " << k;
  }
  EXPECT_NEAR(us(total) / 999.0, 63.87, 1.0) << "us";
  EXPECT_EQ(h.read(CardHost::cs(kFieldIo)), 0x00420000U);
  EXPECT_EQ(h.read(CardHost::cs(kAnalog)), 0x00420000U);
  // The field I/O cable pulled: the next DOIT fails channel 0 after 87-89 us, CS 0x00422008
  // (timeout in the error log, communication error in the status).
  card.part<hm2::Sslbp>().link(kFieldIo).setConnected(false);
  h.write(Sslbp::kCommand, cmd::kDoit | 0x03);
  const SimTime pulled = waitPolled(h);
  EXPECT_NEAR(us(pulled), 88.0, 2.0) << "us";
  EXPECT_EQ(h.read(Sslbp::kData), 0x01U);
  EXPECT_EQ(h.read(CardHost::cs(kFieldIo)), 0x00422008U);
  EXPECT_EQ(h.read(CardHost::cs(kAnalog)), 0x00420000U);
}

// The remote's fault byte in CS byte 3 (manual: CS REGISTER AFTER DOIT) is left by SSLBP 43's stop
// and channel init, which rewrite CS bytes 2..0 only; only the reset clears it.
TEST(Sslbp, RemoteFaultByteSurvivesStopAndStartAsInFirmware43) {
  hm2::HostMot2Card card(separateVin());
  CardHost h{card};
  h.accessTime = SimTime{20};
  auto& io = card.daughtercard(0).fieldIo;
  h.command(cmd::kStop);
  h.write(CardHost::cs(kFieldIo), 0);
  h.write(CardHost::cs(kAnalog), 0);
  ASSERT_EQ(h.command(cmd::kStart | 0x03), 0);
  ASSERT_EQ(h.command(cmd::kDoit | 0x03), 0);
  // Field power dropped: LowVoltageFault, CS 0x20422140 with DATA 0 (firmware and lbpkit).
  io.setFieldVoltage(2.0, h.now);
  for (int k = 0; k < 100 && (h.read(CardHost::cs(kFieldIo)) >> 24) == 0; ++k) {
    h.wait(1ms);
    ASSERT_EQ(h.command(cmd::kDoit | 0x03), 0);
  }
  ASSERT_EQ(h.read(CardHost::cs(kFieldIo)), 0x20422140U);
  io.setFieldVoltage(24.0, h.now);  // power back; the remote keeps the fault latched
  // STOP 0x0803: firmware CS 0x2000C100.
  EXPECT_EQ(h.command(cmd::kStop | 0x03), 0U);
  EXPECT_EQ(h.read(CardHost::cs(kFieldIo)), 0x2000C100U);
  // SETUP START 0x0F03 and every setup-mode LBP command after it: firmware CS 0x20400000.
  h.write(CardHost::cs(kFieldIo), 0);
  h.write(CardHost::cs(kAnalog), 0);
  ASSERT_EQ(h.command(cmd::kSetupStart | 0x03), 0);
  EXPECT_EQ(h.read(CardHost::cs(kFieldIo)), 0x20400000U);
  h.remote(kFieldIo, 0x4C, 0x0694);  // one-byte read of the PTOC, as LinuxCNC's discovery does
  EXPECT_EQ(h.read(CardHost::cs(kFieldIo)), 0x20400000U);
  h.remote(kFieldIo, 0x47, 0x0694);  // lbpkit's 8-byte read
  EXPECT_EQ(h.read(CardHost::cs(kFieldIo)), 0x20400000U);
  // STOP ALL 0x0800, 100 us later: firmware CS 0x2000C100.
  h.command(cmd::kStop);
  h.wait(100us);
  EXPECT_EQ(h.read(CardHost::cs(kFieldIo)), 0x2000C100U);
  // mesaflash's reset (0x4800, then STOP ALL) clears it: SETUP START of channel 0, CS 0x00400000.
  h.write(Sslbp::kCommand, cmd::kReset | cmd::kStop);
  h.write(Sslbp::kCommand, cmd::kStop);
  ASSERT_GE(waitPolled(h).count(), 0);
  h.write(CardHost::cs(kFieldIo), 0);
  ASSERT_EQ(h.command(cmd::kSetupStart | 0x01), 0);
  EXPECT_EQ(h.read(CardHost::cs(kFieldIo)), 0x00400000U);
}

// START of channels the hardware does not have (mesaflash starts channels 0..7 on a 3-channel
// SSLBP): DATA is the channel's bit, after the divisor computation the firmware runs before its
// channel check (SSLBP 43: 18.3-18.5 us).
TEST(Sslbp, StartOfAMissingChannelTakesAsLongAsFirmware43) {
  hm2::HostMot2Card card(threeChannels());
  CardHost h{card};
  h.accessTime = SimTime{20};
  h.command(cmd::kStop);
  for (unsigned ch = 3; ch < 8; ++ch) {
    for (const auto start : {cmd::kSetupStart, cmd::kStart}) {
      h.write(Sslbp::kCommand, start | (1U << ch));
      const SimTime t = waitPolled(h);
      EXPECT_NEAR(us(t), 18.4, 0.15) << "us, channel " << ch;
      EXPECT_EQ(h.read(Sslbp::kData), 1U << ch);
    }
  }
}

// STOP clears every interface register, byte 2 of interface 0 (inputs 16..23 of the field I/O)
// too: SSLBP.MAC initchannel skips that byte, but sserialwa.vhd writes a host register only with
// its byte 3, bytes 0..2 from a latch each register write clears.
TEST(Sslbp, StopClearsAllOfInterface0AsFirmware43) {
  hm2::HostMot2Card card(threeChannels());
  CardHost h{card};
  h.accessTime = SimTime{20};
  auto& io = card.daughtercard(0).fieldIo;
  for (unsigned i = 16; i < 24; ++i) io.setInputVoltage(i, 24.0);
  for (const std::uint32_t stop : {std::uint32_t{cmd::kStop}, cmd::kStop | 0x01U}) {
    startBoth(h);
    ASSERT_EQ(h.command(cmd::kDoit | 0x03), 0);
    ASSERT_EQ(h.read(CardHost::iface(0, kFieldIo)), 0x00FF0000U);  // firmware: the same
    h.command(stop);
    // Firmware: 100 us after STOP ALL, and at once after STOP 0x0801 (3.99 us).
    if (stop == cmd::kStop) h.wait(100us);
    EXPECT_EQ(h.read(CardHost::cs(kFieldIo)), 0x0000C100U) << std::hex << stop;
    for (unsigned n = 0; n < 3; ++n) {
      EXPECT_EQ(h.read(CardHost::iface(n, kFieldIo)), 0U) << std::hex << stop << " " << n;
    }
    // STOP 0x0801 leaves channel 1 running: firmware CS 0x00420000.
    if (stop != cmd::kStop) {
      EXPECT_EQ(h.read(CardHost::cs(kAnalog)), 0x00420000U);
    }
  }
}

// A remote fault during the normal run is reported in CS but not counted (SSLBP.JMP
// dorecvgeneric sets the error without the dead-end counter): held for 1100 DOITs, SSLBP 43
// reads CS 0x20422140 (field power off: LowVoltageFault) or 0x04422140 (an output driver
// over-temperature) with DATA 0 after every one of them, and never TooManyErrors.
TEST(Sslbp, HeldRemoteFaultNeverRaisesTooManyErrorsAsFirmware43) {
  hm2::HostMot2Card card(separateVin());
  CardHost h{card};
  h.accessTime = SimTime{20};
  auto& io = card.daughtercard(0).fieldIo;
  struct Held {
    void (*set)(remote::FieldIoProcessor&, bool, SimTime);
    std::uint32_t cs;
    std::uint32_t csAtStart;  // chattering after the normal START before it
  };
  const Held faults[] = {
      {[](remote::FieldIoProcessor& f, bool on, SimTime t) { f.setFieldVoltage(on ? 0.0 : 24.0, t); }, 0x20422140U,
       0x003B0000U},
      // The START clears the remote's LowVoltageFault; reading 0 it leaves CS byte 3 as it was
      // (SSLBP.JMP dochkgenfaults stores only a non-zero fault byte): firmware 0x203B0000.
      {[](remote::FieldIoProcessor& f, bool on, SimTime) { f.setDriverOverTemperature(0, on); }, 0x04422140U,
       0x203B0000U},
  };
  for (const auto& f : faults) {
    startBoth(h);
    EXPECT_EQ(h.read(CardHost::cs(kFieldIo)) & 0xFF00FFFFU, f.csAtStart & 0xFF00FFFFU);  // COM_STATE 3A/3B
    f.set(io, true, h.now);
    for (int k = 0; k < 1100; ++k) {
      h.write(CardHost::iface(0, kFieldIo), 0x00FF);
      ASSERT_EQ(h.command(cmd::kDoit | 0x03), 0) << "DOIT " << k + 1;
      ASSERT_EQ(h.read(CardHost::cs(kFieldIo)), f.cs) << "DOIT " << k + 1;
    }
    f.set(io, false, h.now);
    ASSERT_EQ(h.command(cmd::kDoit | 0x03), 0);  // the fault stays latched in the remote
    EXPECT_EQ(h.read(CardHost::cs(kFieldIo)), f.cs);
    EXPECT_EQ(h.read(CardHost::cs(kAnalog)), 0x00420000U);
  }
}

// The M bit (manual: COMMAND REGISTER, "ROM enable/reset bit"; sserialwa.vhd romwrena): the
// processor is held in reset, DATA reads and writes the 16-bit program ROM word COMMAND bits
// 10..0 address, and releasing M boots the processor: the command written then is not run, the
// RAM (baud rates, remote fault bytes) is back at its boot values.
TEST(Sslbp, MBitGivesTheHostTheRomAndBootsOnReleaseAsFirmware43) {
  hm2::HostMot2Card card(threeChannels());
  CardHost h{card};
  h.accessTime = SimTime{20};
  auto& io = card.daughtercard(0).fieldIo;
  auto& sserial = card.part<hm2::Sslbp>();
  // A remote fault byte in CS (driver over-temperature) and channel 0's baud rate changed.
  startBoth(h);
  io.setDriverOverTemperature(0, true);
  ASSERT_EQ(h.command(cmd::kDoit | 0x03), 0);
  ASSERT_EQ(h.read(CardHost::cs(kFieldIo)), 0x04422140U);
  h.command(cmd::kStop);
  const std::uint16_t baud0 = hm2::local::kChannelBlock + hm2::local::kBaudOffset;
  for (unsigned k = 0; k < 4; ++k) {
    h.write(Sslbp::kData, (115200U >> (8 * k)) & 0xFF);
    h.command(cmd::kWrite | cmd::kRequest | (baud0 + k));
  }
  ASSERT_EQ(localRead(h, static_cast<std::uint16_t>(baud0 + 1)), (115200 >> 8) & 0xFF);

  // M set: the ROM. Firmware: word 0x7FF reads 0xABCD (SSLBP.ASM's ROM cookie), COMMAND reads
  // back as written, CS keeps the fault byte (0x0400C100).
  h.write(Sslbp::kCommand, cmd::kReset | 0x7FF);
  EXPECT_TRUE(sserial.processorInReset());
  EXPECT_EQ(h.read(Sslbp::kData), 0xABCDU);
  EXPECT_EQ(h.read(Sslbp::kCommand), 0x47FFU);
  EXPECT_EQ(h.read(CardHost::cs(kFieldIo)), 0x0400C100U);
  h.wait(1ms);  // held: nothing runs
  EXPECT_EQ(h.read(Sslbp::kCommand), 0x47FFU);
  // A word written through DATA (16 bits kept) lands a few clocks later. Firmware: a read 20 ns
  // after the write returns the old word, 100 ns after it the new one.
  h.write(Sslbp::kCommand, cmd::kReset | 0x123);
  const auto old = h.read(Sslbp::kData);
  h.write(Sslbp::kData, 0xFFFFC3A5U);
  EXPECT_EQ(h.read(Sslbp::kData), old);
  h.wait(SimTime{100});
  EXPECT_EQ(h.read(Sslbp::kData), 0xC3A5U);
  h.write(Sslbp::kCommand, cmd::kReset | 0x124);
  EXPECT_NE(h.read(Sslbp::kData), 0xC3A5U);
  EXPECT_EQ(sserial.romWord(0x123), 0xC3A5U);

  // Released by a local read of the version: firmware COMMAND reads 0x2003 until it clears
  // 21.6 us later; DATA is then 0xAA, and still 200 us later (the read was not run).
  h.write(Sslbp::kCommand, cmd::kRequest | hm2::local::kMinorRev);
  EXPECT_FALSE(sserial.processorInReset());
  EXPECT_EQ(h.read(Sslbp::kCommand), 0x2003U);
  const SimTime boot = waitPolled(h);
  EXPECT_NEAR(us(boot), 21.6, 0.3);
  EXPECT_EQ(h.read(Sslbp::kData), 0xAAU);
  h.wait(200us);
  EXPECT_EQ(h.read(Sslbp::kData), 0xAAU);
  // Booted: firmware version 43, channel 0 at the default 2.5 MBaud again, CS 0x0000C100.
  EXPECT_EQ(localRead(h, hm2::local::kMinorRev), 43);
  for (std::uint16_t k = 0; k < 4; ++k) {
    EXPECT_EQ(localRead(h, static_cast<std::uint16_t>(baud0 + k)), (2500000U >> (8 * k)) & 0xFF) << k;
  }
  EXPECT_EQ(h.read(CardHost::cs(kFieldIo)), 0x0000C100U);
  EXPECT_EQ(h.read(Sslbp::kData) & 0xFFFF0000U, 0U);
  io.setDriverOverTemperature(0, false);
  h.write(CardHost::cs(kFieldIo), 0);
  h.write(CardHost::cs(kAnalog), 0);
  EXPECT_EQ(h.command(cmd::kStart | 0x03), 0);
  EXPECT_EQ(h.command(cmd::kDoit | 0x03), 0);
  // The downloaded word stays until the FPGA is configured again (power-up).
  EXPECT_EQ(sserial.romWord(0x123), 0xC3A5U);
  sserial.reset();
  EXPECT_EQ(sserial.romWord(0x123), 0U);
  EXPECT_EQ(sserial.romWord(Sslbp::kRomCookieAddress), Sslbp::kRomCookie);
}

// A command written while the processor boots (after M is released, before COMMAND clears) is
// lost with the boot's command clear.
TEST(Sslbp, CommandWrittenWhileBootingIsLost) {
  hm2::HostMot2Card card(threeChannels());
  CardHost h{card};
  h.accessTime = SimTime{20};
  h.write(Sslbp::kCommand, cmd::kReset);
  h.write(Sslbp::kCommand, 0x0001);
  h.wait(5us);
  h.write(Sslbp::kCommand, cmd::kRequest | hm2::local::kMinorRev);
  EXPECT_EQ(card.part<hm2::Sslbp>().counters().lostCommands, 1U);
  ASSERT_GE(waitPolled(h).count(), 0);
  EXPECT_EQ(h.read(Sslbp::kData), 0xAAU);
  EXPECT_EQ(localRead(h, hm2::local::kMinorRev), 43);
}

// With 6 channels (two 7I77s) the boot after M clears the remote fault byte of channels 0..2 only:
// initmem clears RAM 0x000..0x0FF, and channel 3's block starts at 0x106. The 6-channel SSLBP 43
// with lbpkit's field I/O processor on channel 3 (and, the same, 5): CS 0x2000C100 after STOP ALL,
// while M is held, 200 us after its release, and 0x20400000 after the next setup START; on channel
// 0: 0x0000C100 after the release.
TEST(Sslbp, BootAfterMKeepsTheFaultByteOfChannelsAbove2AsFirmware43) {
  for (const unsigned ch : {0U, 3U, 5U}) {
    hm2::Sslbp ss(6);
    remote::FieldIoProcessor::Options o;
    o.vinFromField = false;
    o.vin = 24;
    remote::FieldIoProcessor io(o);
    ss.link(ch).attach(&io);
    SimTime now{};
    const auto at = [&](SimTime t) {
      now += t;
      io.advance(now);
    };
    const auto write = [&](std::uint16_t a, std::uint32_t v) {
      at(SimTime{20});
      ss.write(a, v, now);
    };
    const auto read = [&](std::uint16_t a) {
      at(SimTime{20});
      return ss.read(a, now);
    };
    const auto command = [&](std::uint32_t c) {
      write(Sslbp::kCommand, c);
      for (int k = 0; k < 1'000'000 && read(Sslbp::kCommand) != 0; ++k) at(SimTime{200});
      EXPECT_EQ(read(Sslbp::kCommand), 0U) << std::hex << c;
      return read(Sslbp::kData) & 0xFF;
    };
    const auto csAddress = static_cast<std::uint16_t>(Sslbp::kCs + 4 * ch);
    command(cmd::kStop);
    write(csAddress, 0);
    ASSERT_EQ(command(cmd::kStart | (1U << ch)), 0U) << ch;
    io.setFieldVoltage(0.0, now);
    for (int k = 0; k < 3; ++k) ASSERT_EQ(command(cmd::kDoit | (1U << ch)), 0U) << ch;
    ASSERT_EQ(read(csAddress), 0x20422140U) << ch;
    io.setFieldVoltage(24.0, now);
    command(cmd::kStop);
    at(100us);
    EXPECT_EQ(read(csAddress), 0x2000C100U) << ch;
    write(Sslbp::kCommand, cmd::kReset);
    EXPECT_EQ(read(csAddress), 0x2000C100U) << ch;
    write(Sslbp::kCommand, 0x0001);
    at(200us);
    const std::uint32_t fault = ch < 3 ? 0 : 0x20000000U;
    EXPECT_EQ(read(csAddress), fault | 0x0000C100U) << ch;
    write(csAddress, 0);
    EXPECT_EQ(command(cmd::kSetupStart | (1U << ch)), 0U) << ch;
    EXPECT_EQ(read(csAddress), fault | 0x00400000U) << ch;
  }
}

}  // namespace
