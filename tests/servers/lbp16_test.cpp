// SPDX-License-Identifier: MIT
// The virtual card's LBP16 face, datagram by datagram.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <unistd.h>
#include <vector>

#include "hostmot2/card.hpp"
#include "lbp16/lbp16_card.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace server = lbpkit::server;

namespace {

using Bytes = std::vector<std::uint8_t>;
using server::lbp16::Command;

struct Lbp16Test : ::testing::Test {
  hm2::HostMot2Card card;
  server::Lbp16Card lbp16{card, server::Lbp16Card::Identity{}};
  hm2::SimTime now{0};

  static void cmd(Bytes& d, Command c, std::optional<std::uint16_t> addr = std::nullopt) {
    c.hasAddress = addr.has_value();
    const auto w = c.encode();
    d.push_back(static_cast<std::uint8_t>(w));
    d.push_back(static_cast<std::uint8_t>(w >> 8));
    if (addr) {
      d.push_back(static_cast<std::uint8_t>(*addr));
      d.push_back(static_cast<std::uint8_t>(*addr >> 8));
    }
  }
  Bytes send(const Bytes& d) {
    std::array<std::uint8_t, server::Lbp16Card::kMaxDatagram> reply{};
    now += hm2::SimTime{100'000};
    const auto n = lbp16.handle(d, reply, now);
    return Bytes(reply.begin(), reply.begin() + static_cast<std::ptrdiff_t>(n));
  }
  static std::uint32_t u32(const Bytes& b, std::size_t at) {
    return std::uint32_t{b[at]} | (std::uint32_t{b[at + 1]} << 8) | (std::uint32_t{b[at + 2]} << 16) |
           (std::uint32_t{b[at + 3]} << 24);
  }
};

TEST_F(Lbp16Test, CommandWordMatchesTheWordsRealClientsSend) {
  EXPECT_EQ(server::lbp16::hm2Read(1), 0x4281);                              // read HM2 1x32 auto-inc
  EXPECT_EQ(server::lbp16::hm2Write(1), 0xC281);                             // hm2_eth's watchdog pet
  EXPECT_EQ((Command{false, true, false, 7, 2, true, 8}.encode()), 0x5D88);  // board name
  EXPECT_EQ((Command{false, true, false, 2, 2, true, 3}.encode()), 0x4983);  // MAC
  EXPECT_EQ((Command{true, true, false, 4, 2, true, 2}.encode()), 0xD182);   // read counter
  EXPECT_EQ((Command{false, true, true, 0, 2, true, 8}.encode()), 0x6188);   // area info
  const auto c = Command::decode(0x4E40);
  EXPECT_FALSE(c.write);
  EXPECT_EQ(c.space, 3);
  EXPECT_EQ(c.size, 4);
  EXPECT_FALSE(c.autoIncrement);
  EXPECT_EQ(c.count, 64);
}

TEST_F(Lbp16Test, SeveralCommandsInOneDatagramInOrder) {
  Bytes d;
  cmd(d, {false, true, false, 0, 4, true, 4}, 0x0100);  // cookie, "HOST", "MOT2", IDROM pointer
  cmd(d, {true, true, false, 4, 2, true, 2}, 0x0010);   // hm2_eth's read counter...
  d.insert(d.end(), {0x34, 0x12, 0x78, 0x56});
  cmd(d, {false, true, false, 4, 2, true, 4}, 0x0010);  // ...echoed in the same datagram
  cmd(d, {false, true, false, 0, 4, true, 2}, 0x0100);  // two 32-bit reads
  const auto r = send(d);
  ASSERT_EQ(r.size(), 16U + 8U + 8U);
  EXPECT_EQ(u32(r, 0), 0x55AACAFEU);
  EXPECT_EQ(u32(r, 12), 0x0400U);
  EXPECT_EQ(u32(r, 16), 0x56781234U);
  EXPECT_EQ(u32(r, 24), 0x55AACAFEU);
  EXPECT_EQ(u32(r, 28), 0x54534F48U);  // the next word: "HOST"
}

TEST_F(Lbp16Test, AutoIncrementAndTheAddressPointer) {
  Bytes d;
  cmd(d, {false, true, false, 0, 4, false, 3}, 0x0100);  // no auto-increment: same word thrice
  cmd(d, {false, false, false, 0, 4, true, 1});          // no address: continues at 0x0100
  const auto r = send(d);
  ASSERT_EQ(r.size(), 16U);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_EQ(u32(r, 4 * i), 0x55AACAFEU) << i;
  Bytes e;
  cmd(e, {false, false, false, 0, 4, true, 1});  // the pointer moved past 0x0100
  EXPECT_EQ(u32(send(e), 0), 0x54534F48U);
}

TEST_F(Lbp16Test, CountsOf127AndBoardIdentity) {
  Bytes d;
  cmd(d, {false, true, false, 0, 4, true, 127}, 0x0400);  // most of the IDROM in one command
  const auto r = send(d);
  ASSERT_EQ(r.size(), 508U);
  EXPECT_EQ(u32(r, 0), 3U);                 // IDROM type
  EXPECT_EQ(u32(r, 0x24), 17U);             // port width
  Bytes n;
  cmd(n, {false, true, false, 7, 2, true, 8}, 0);
  const auto name = send(n);
  ASSERT_EQ(name.size(), 16U);
  EXPECT_EQ(std::string(name.begin(), name.begin() + 4), "7I92");
  for (std::size_t i = 4; i < 16; ++i) EXPECT_EQ(name[i], 0) << "NUL padded, not spaces";
  Bytes m;
  cmd(m, {false, true, false, 2, 2, true, 3}, 2);
  const auto mac = send(m);  // hm2_eth reverses these six bytes
  ASSERT_EQ(mac.size(), 6U);
  const auto& id = lbp16.identity();
  EXPECT_EQ(mac[5], id.mac[0]);
  EXPECT_EQ(mac[0], id.mac[5]);
  Bytes info;
  cmd(info, {false, true, true, 3, 2, true, 8}, 0);  // flash area info
  const auto a = send(info);
  ASSERT_EQ(a.size(), 16U);
  EXPECT_EQ(std::string(a.begin() + 8, a.begin() + 16).c_str(), std::string("FPGAFlsh"));
}

TEST_F(Lbp16Test, BadDatagramsAreCountedAndAnsweredAsFarAsTheyParse) {
  EXPECT_TRUE(send({0x81}).empty());  // half a command word
  EXPECT_EQ(lbp16.counters().parseErrors, 1U);
  Bytes d;
  cmd(d, {false, true, false, 0, 4, true, 1}, 0x0100);
  d.push_back(0x81);  // a good read, then a truncated command
  EXPECT_EQ(send(d).size(), 4U);
  EXPECT_EQ(lbp16.counters().parseErrors, 2U);
  Bytes w;
  cmd(w, {true, true, false, 0, 4, true, 2}, 0x1400);
  w.insert(w.end(), {1, 2, 3});  // write data missing
  EXPECT_TRUE(send(w).empty());
  EXPECT_EQ(card.read32(0x1400, now), 0U);
  // Unknown space, unsupported width (parse errors in the firmware), past
  // the end (memory errors): zeros, full length, counted.
  Bytes u;
  cmd(u, {false, true, false, 5, 2, true, 4}, 0);
  cmd(u, {false, true, false, 0, 2, true, 2}, 0x0100);
  cmd(u, {false, true, false, 7, 2, true, 4}, 0x1E);
  const auto r = send(u);
  ASSERT_EQ(r.size(), 8U + 4U + 8U);
  for (std::size_t i = 0; i < 12; ++i) EXPECT_EQ(r[i], 0) << i;
  EXPECT_EQ(lbp16.counters().parseErrors, 3U + 2U);
  EXPECT_EQ(lbp16.counters().memoryErrors, 3U);
  // Writes to read-only spaces and to the EEPROM without its enable.
  Bytes ro;
  cmd(ro, {true, true, false, 7, 2, true, 1}, 0);
  ro.insert(ro.end(), {'X', 'X'});
  cmd(ro, {true, true, false, 2, 2, true, 1}, 0x20);
  ro.insert(ro.end(), {9, 9});
  EXPECT_TRUE(send(ro).empty());
  EXPECT_EQ(lbp16.counters().writeErrors, 2U);
  Bytes n;
  cmd(n, {false, true, false, 7, 2, true, 1}, 0);
  EXPECT_EQ(send(n), (Bytes{'7', 'I'}));
  // With the write enable (space 6 @0x1A = 0x5A02) in the same datagram it takes.
  Bytes en;
  cmd(en, {true, true, false, 6, 2, true, 1}, 0x1A);
  en.insert(en.end(), {0x02, 0x5A});
  cmd(en, {true, true, false, 2, 2, true, 1}, 0x28);
  en.insert(en.end(), {0x01, 0x00});
  cmd(en, {false, true, false, 2, 2, true, 1}, 0x28);
  EXPECT_EQ(send(en), (Bytes{0x01, 0x00}));
  // Oversized: refused whole (a receive error: a real card never gets it whole).
  EXPECT_TRUE(send(Bytes(2000, 0x42)).empty());
  EXPECT_EQ(lbp16.counters().rxErrors, 1U);
  // And the card still answers.
  Bytes c;
  cmd(c, {false, true, false, 0, 4, true, 1}, 0x0100);
  EXPECT_EQ(u32(send(c), 0), 0x55AACAFEU);
}

TEST_F(Lbp16Test, FlashProgramsOnlyWithItsWriteEnable) {
  auto setAddress = [&](Bytes& d, std::uint32_t a) {
    cmd(d, {true, true, false, 3, 4, false, 1}, 0x0);
    d.insert(d.end(), {static_cast<std::uint8_t>(a), static_cast<std::uint8_t>(a >> 8), static_cast<std::uint8_t>(a >> 16),
                       static_cast<std::uint8_t>(a >> 24)});
  };
  auto enable = [&](Bytes& d, std::uint16_t key) {
    cmd(d, {true, true, false, 6, 2, true, 1}, 0x1A);
    d.insert(d.end(), {static_cast<std::uint8_t>(key), static_cast<std::uint8_t>(key >> 8)});
  };
  auto program = [&](Bytes& d, std::uint32_t word) {
    cmd(d, {true, true, false, 3, 4, false, 1}, 0x4);
    for (int i = 0; i < 4; ++i) d.push_back(static_cast<std::uint8_t>(word >> (8 * i)));
  };
  auto readWord = [&](std::uint32_t a) {
    Bytes d;
    setAddress(d, a);
    cmd(d, {false, true, false, 3, 4, false, 1}, 0x4);
    return u32(send(d), 0);
  };
  EXPECT_EQ(readWord(0x10000), 0xFFFFFFFFU);  // blank
  Bytes noKey;
  setAddress(noKey, 0x10000);
  program(noKey, 0x12345678);
  send(noKey);
  EXPECT_EQ(readWord(0x10000), 0xFFFFFFFFU);
  EXPECT_EQ(lbp16.counters().writeErrors, 1U);
  Bytes eepromKey;  // the EEPROM's key does not open the flash
  setAddress(eepromKey, 0x10000);
  enable(eepromKey, 0x5A02);
  program(eepromKey, 0x12345678);
  send(eepromKey);
  EXPECT_EQ(readWord(0x10000), 0xFFFFFFFFU);
  Bytes ok;
  setAddress(ok, 0x10000);
  enable(ok, 0x5A03);
  program(ok, 0x12345678);
  program(ok, 0xF0F0F0F0);  // the next word: the address advances
  send(ok);
  EXPECT_EQ(readWord(0x10000), 0x12345678U);
  EXPECT_EQ(readWord(0x10004), 0xF0F0F0F0U);
  Bytes again;  // programming only clears bits
  setAddress(again, 0x10004);
  enable(again, 0x5A03);
  program(again, 0x0F0F0FFF);
  send(again);
  EXPECT_EQ(readWord(0x10004), 0x000000F0U);
  Bytes erase;  // sector erase: 64 KB back to 0xFF
  setAddress(erase, 0x1FFFC);
  enable(erase, 0x5A03);
  cmd(erase, {true, true, false, 3, 4, false, 1}, 0xC);
  erase.insert(erase.end(), {0, 0, 0, 0});
  send(erase);
  EXPECT_EQ(readWord(0x10000), 0xFFFFFFFFU);
  EXPECT_EQ(readWord(0x10004), 0xFFFFFFFFU);
}

TEST_F(Lbp16Test, RepliesNeverExceedOneFrame) {
  Bytes d;
  for (int i = 0; i < 12; ++i) cmd(d, {false, true, false, 0, 4, true, 127}, 0x0400);  // 6096 bytes asked
  const auto r = send(d);
  EXPECT_LE(r.size(), server::Lbp16Card::kMaxDatagram);
  EXPECT_EQ(r.size() % 508, 0U);  // whole commands only
  EXPECT_EQ(lbp16.counters().memoryErrors, 1U);  // the send buffer's limit (LBPPARSE.ASM)
}

// The LBP16 details Mesa's Ethernet firmware has
// (hostmot2-firmware src/etherhm2.zip: ETHERHM2.INC, LBPPARSE.ASM,
// ETHERINI.ASM), as LinuxCNC's lbp16.h and mesaflash name them.

std::uint16_t u16(const Bytes& b, std::size_t at) { return static_cast<std::uint16_t>(b[at] | (b[at + 1] << 8)); }

TEST_F(Lbp16Test, InfoAreaWord3IsTheSpacesAddressPointer) {
  Bytes d;
  cmd(d, {false, true, false, 0, 4, true, 3}, 0x0100);  // leaves the HostMot2 pointer at 0x010C
  cmd(d, {false, true, false, 6, 2, true, 2}, 0x0004);  // the comm space's at 0x0008
  send(d);
  auto info = [&](std::uint8_t space) {
    Bytes q;
    cmd(q, {false, true, true, space, 2, true, 8}, 0);
    return send(q);
  };
  const auto a0 = info(0);
  ASSERT_EQ(a0.size(), 16U);
  EXPECT_EQ(u16(a0, 0), 0x5A00);
  EXPECT_EQ(u16(a0, 6), 0x010C);
  EXPECT_EQ(u16(info(6), 6), 0x0008);
  EXPECT_EQ(u16(info(6), 6), 0x0008);  // reading the info area does not move it
  // A command without an address continues from the pointer.
  Bytes next;
  cmd(next, {false, false, false, 0, 4, true, 1});
  EXPECT_EQ(u32(send(next), 0), 0x0400U);  // 0x010C: the IDROM pointer
  EXPECT_EQ(u16(info(0), 6), 0x0110);
}

TEST_F(Lbp16Test, AreaInfoIsTheFirmwares) {
  // Size word (bit 15 writable, type, widths), ranges, name (ETHERHM2.INC, ETHERINI.ASM).
  const struct {
    std::uint8_t space;
    std::uint16_t size, ranges;
    const char* name;
  } want[] = {{0, 0x8104, 0x0010, "HostMot2"}, {1, 0x8102, 0x0008, "KSZ8851"}, {2, 0x8E02, 0x0007, "EtherEEP"},
              {3, 0x8F04, 0x8215, "FPGAFlsh"}, {4, 0x8202, 0x0004, "Timers"},  {6, 0x8202, 0x0004, "LBP16RW"},
              {7, 0x0202, 0x0004, "LBP16RO"}};
  for (const auto& w : want) {
    Bytes q;
    cmd(q, {false, true, true, w.space, 2, true, 8}, 0);
    const auto a = send(q);
    ASSERT_EQ(a.size(), 16U);
    EXPECT_EQ(u16(a, 0), 0x5A00 | w.space);
    EXPECT_EQ(u16(a, 2), w.size) << int(w.space);
    EXPECT_EQ(u16(a, 4), w.ranges) << int(w.space);
    EXPECT_EQ(std::string(a.begin() + 8, a.end()).c_str(), std::string(w.name));
  }
  // Info areas are 16-bit and read only.
  Bytes bad;
  cmd(bad, {false, true, true, 0, 4, true, 1}, 0);
  cmd(bad, {true, true, true, 0, 2, true, 1}, 0);
  bad.insert(bad.end(), {1, 2});
  send(bad);
  EXPECT_EQ(lbp16.counters().parseErrors, 1U);
  EXPECT_EQ(lbp16.counters().writeErrors, 1U);
}

TEST_F(Lbp16Test, ErrorRegisterHasABitPerKindUntilTheHostClearsIt) {
  auto errorRegister = [&] {
    Bytes q;
    cmd(q, {false, true, false, 6, 2, true, 1}, 0);
    return u16(send(q), 0);
  };
  EXPECT_EQ(errorRegister(), 0);
  send({0x81});  // half a command: parse
  EXPECT_EQ(errorRegister(), 0x01);
  Bytes mem;
  cmd(mem, {false, true, false, 7, 2, true, 1}, 0x40);  // past the end: memory
  send(mem);
  EXPECT_EQ(errorRegister(), 0x03);
  Bytes wr;
  cmd(wr, {true, true, false, 7, 2, true, 1}, 0);  // read-only space: write
  wr.insert(wr.end(), {1, 2});
  send(wr);
  EXPECT_EQ(errorRegister(), 0x07);
  send(Bytes(1500, 0));  // more than a frame: receive
  EXPECT_EQ(errorRegister(), 0x0F);
  lbp16.noteSendFailed();  // the reply did not go out: transmit
  EXPECT_EQ(errorRegister(), 0x1F);
  Bytes wait;
  cmd(wait, {false, true, false, 4, 2, true, 1}, 0x06);  // WaitForHM2RefTime: no HM2 timer here, times out
  send(wait);
  EXPECT_EQ(errorRegister(), 0x3F);
  EXPECT_EQ(lbp16.errorRegister(), 0x3F);
  // The counters beside it, in lbp16.h's order.
  Bytes all;
  cmd(all, {false, true, false, 6, 2, true, 10}, 0);
  const auto c = send(all);
  EXPECT_EQ(u16(c, 2), 1);   // parse errors
  EXPECT_EQ(u16(c, 4), 1);   // memory errors
  EXPECT_EQ(u16(c, 6), 1);   // write errors
  EXPECT_EQ(u16(c, 8), 13);  // datagrams received (this one too)
  EXPECT_EQ(u16(c, 12), 1);  // received bad
  EXPECT_EQ(u16(c, 18), 1);  // sent bad
  // The host clears the register (and may reset the counters) by writing it.
  Bytes clear;
  cmd(clear, {true, true, false, 6, 2, true, 2}, 0);
  clear.insert(clear.end(), {0, 0, 0, 0});
  send(clear);
  EXPECT_EQ(errorRegister(), 0);
  EXPECT_EQ(lbp16.counters().parseErrors, 1U);  // the control API's totals stay
}

TEST_F(Lbp16Test, EepromMacAndNameAreReadOnlyTheRestWritable) {
  auto enabled = [&](std::uint16_t address, std::uint16_t value) {
    Bytes d;
    cmd(d, {true, true, false, 6, 2, true, 1}, 0x1A);
    d.insert(d.end(), {0x02, 0x5A});
    cmd(d, {true, true, false, 2, 2, true, 1}, address);
    d.insert(d.end(), {static_cast<std::uint8_t>(value), static_cast<std::uint8_t>(value >> 8)});
    cmd(d, {false, true, false, 2, 2, true, 1}, address);
    return u16(send(d), 0);
  };
  const auto before = lbp16.eeprom();
  EXPECT_NE(enabled(0x02, 0x1234), 0x1234);  // MAC
  EXPECT_NE(enabled(0x06, 0x1234), 0x1234);
  EXPECT_NE(enabled(0x10, 0x4141), 0x4141);  // board name
  EXPECT_NE(enabled(0x1E, 0x4141), 0x4141);
  EXPECT_EQ(lbp16.counters().writeErrors, 4U);
  EXPECT_EQ(lbp16.eeprom().mac, before.mac);
  EXPECT_EQ(lbp16.eeprom().name, before.name);
  EXPECT_EQ(enabled(0x20, 0x0A0B), 0x0A0B);  // IP
  EXPECT_EQ(enabled(0x28, 0x0001), 0x0001);  // LED debug (mesaflash --set ledmode)
  EXPECT_EQ(lbp16.counters().writeErrors, 4U);
  // 16-bit only.
  Bytes byte;
  cmd(byte, {false, true, false, 2, 1, true, 2}, 0x20);
  EXPECT_EQ(send(byte), (Bytes{0, 0}));
  EXPECT_EQ(lbp16.counters().parseErrors, 1U);
}

TEST_F(Lbp16Test, EthernetChipSpaceIsWritable) {
  Bytes d;
  cmd(d, {true, true, false, 1, 2, true, 2}, 0x70);
  d.insert(d.end(), {0xEF, 0x01, 0x34, 0x12});
  cmd(d, {false, true, false, 1, 2, true, 2}, 0x70);
  const auto r = send(d);
  ASSERT_EQ(r.size(), 4U);
  EXPECT_EQ(u16(r, 0), 0x01EF);
  EXPECT_EQ(u16(r, 2), 0x1234);
  EXPECT_EQ(lbp16.counters().writeErrors, 0U);
}

TEST_F(Lbp16Test, HostMot2SpaceIs32BitOnly) {
  Bytes d;
  cmd(d, {false, true, false, 0, 8, true, 1}, 0x0100);
  cmd(d, {true, true, false, 0, 8, true, 1}, 0x1400);
  d.insert(d.end(), {5, 0, 0, 0, 6, 0, 0, 0});
  const auto r = send(d);
  EXPECT_EQ(r, Bytes(8, 0));
  EXPECT_EQ(lbp16.counters().parseErrors, 2U);
  EXPECT_EQ(card.read32(0x1400, now), 0U);  // nothing written
}

TEST_F(Lbp16Test, TimerSpaceWaitsAndScratchWords) {
  // WaituS: a write waits that many microseconds (the rest of the datagram
  // happens later), a read gives the last wait.
  Bytes d;
  cmd(d, {false, true, false, 4, 2, true, 1}, 0x00);
  cmd(d, {true, true, false, 4, 2, true, 1}, 0x02);
  d.insert(d.end(), {0xF4, 0x01});  // 500 us
  cmd(d, {false, true, false, 4, 2, true, 2}, 0x00);
  auto r = send(d);
  ASSERT_EQ(r.size(), 6U);
  EXPECT_EQ(static_cast<std::uint16_t>(u16(r, 2) - u16(r, 0)), 500);
  EXPECT_EQ(u16(r, 4), 500);
  // HM2Timeout bounds the WaitForHM2 waits; with no HostMot2 timer in this
  // firmware they wait all of it and return it.
  Bytes w;
  cmd(w, {true, true, false, 4, 2, true, 1}, 0x04);
  w.insert(w.end(), {100, 0});
  cmd(w, {false, true, false, 4, 2, true, 1}, 0x00);
  cmd(w, {false, true, false, 4, 2, true, 5}, 0x06);  // WaitForHM2RefTime, WaitForHM2Timer1..4
  cmd(w, {false, true, false, 4, 2, true, 1}, 0x00);
  cmd(w, {false, true, false, 4, 2, true, 1}, 0x04);
  r = send(w);
  ASSERT_EQ(r.size(), 2U + 10U + 4U);
  for (std::size_t i = 2; i < 12; i += 2) EXPECT_EQ(u16(r, i), 100) << i;
  EXPECT_EQ(static_cast<std::uint16_t>(u16(r, 12) - u16(r, 0)), 500);
  EXPECT_EQ(u16(r, 14), 100);  // HM2Timeout reads back
  EXPECT_EQ(lbp16.counters().hm2Timeouts, 5U);
  // Eight scratch words at 0x10..0x1F.
  Bytes sc;
  cmd(sc, {true, true, false, 4, 2, true, 8}, 0x10);
  for (std::uint8_t i = 0; i < 16; ++i) sc.push_back(i);
  cmd(sc, {false, true, false, 4, 2, true, 8}, 0x10);
  r = send(sc);
  ASSERT_EQ(r.size(), 16U);
  for (std::uint8_t i = 0; i < 16; ++i) EXPECT_EQ(r[i], i);
  EXPECT_EQ(lbp16.counters().memoryErrors, 0U);
}

// The configuration flash is kept in a file.
struct FlashFileTest : ::testing::Test {
  std::filesystem::path file = std::filesystem::temp_directory_path() / ("lbpkit-flash-" + std::to_string(::getpid()));
  void SetUp() override {
    std::filesystem::remove(file);
    std::filesystem::remove(file.string() + ".tmp");
  }
  void TearDown() override { SetUp(); }
  static Bytes programWord(std::uint32_t address, std::uint32_t word) {
    Bytes d;
    Lbp16Test::cmd(d, {true, true, false, 6, 2, true, 1}, 0x1A);
    d.insert(d.end(), {0x03, 0x5A});
    Lbp16Test::cmd(d, {true, true, false, 3, 4, false, 1}, 0x0);
    for (int i = 0; i < 4; ++i) d.push_back(static_cast<std::uint8_t>(address >> (8 * i)));
    Lbp16Test::cmd(d, {true, true, false, 3, 4, false, 1}, 0x4);
    for (int i = 0; i < 4; ++i) d.push_back(static_cast<std::uint8_t>(word >> (8 * i)));
    return d;
  }
  static std::uint32_t readWord(server::Lbp16Card& c, std::uint32_t address) {
    Bytes d;
    Lbp16Test::cmd(d, {true, true, false, 3, 4, false, 1}, 0x0);
    for (int i = 0; i < 4; ++i) d.push_back(static_cast<std::uint8_t>(address >> (8 * i)));
    Lbp16Test::cmd(d, {false, true, false, 3, 4, false, 1}, 0x4);
    std::array<std::uint8_t, server::Lbp16Card::kMaxDatagram> reply{};
    c.handle(d, reply, hm2::SimTime{1});
    return Lbp16Test::u32(Bytes(reply.begin(), reply.begin() + 4), 0);
  }
  server::Lbp16Card::Identity identity() const {
    server::Lbp16Card::Identity id;
    id.flashFile = file;
    return id;
  }
};

TEST_F(FlashFileTest, WhatWasProgrammedIsThereAfterARestart) {
  hm2::HostMot2Card card;
  {
    server::Lbp16Card lbp16(card, identity());
    EXPECT_EQ(readWord(lbp16, 0x1000), 0xFFFFFFFFU);  // no file: blank
    std::array<std::uint8_t, server::Lbp16Card::kMaxDatagram> reply{};
    lbp16.handle(programWord(0x1000, 0xA5A55A5A), reply, hm2::SimTime{1});
    lbp16.handle(programWord(0x1FFFFC, 0x01020304), reply, hm2::SimTime{2});
  }  // the card powers off: what changed is saved
  ASSERT_TRUE(std::filesystem::exists(file));
  EXPECT_FALSE(std::filesystem::exists(file.string() + ".tmp"));
  server::Lbp16Card again(card, identity());
  EXPECT_EQ(readWord(again, 0x1000), 0xA5A55A5AU);
  EXPECT_EQ(readWord(again, 0x1FFFFC), 0x01020304U);
  EXPECT_EQ(readWord(again, 0x1004), 0xFFFFFFFFU);
}

TEST_F(FlashFileTest, ASaveCutShortLeavesTheOldImage) {
  std::vector<std::uint8_t> image(2 * 1024 * 1024, 0xFF);
  image[0] = 0x11;
  ASSERT_EQ(server::saveFlashFile(file, image), "");
  // A save that died before its rename leaves FILE.tmp beside the old file.
  std::ofstream(file.string() + ".tmp", std::ios::binary) << "LBFLASH1 torn";
  hm2::HostMot2Card card;
  {
    server::Lbp16Card lbp16(card, identity());
    EXPECT_EQ(readWord(lbp16, 0) & 0xFF, 0x11U);
    std::array<std::uint8_t, server::Lbp16Card::kMaxDatagram> reply{};
    lbp16.handle(programWord(4, 0x22), reply, hm2::SimTime{1});
  }
  server::Lbp16Card again(card, identity());
  EXPECT_EQ(readWord(again, 0) & 0xFF, 0x11U);
  EXPECT_EQ(readWord(again, 4), 0x22U);
  EXPECT_FALSE(std::filesystem::exists(file.string() + ".tmp"));
}

TEST_F(FlashFileTest, AFileThatIsNotAFlashImageIsRefusedAndKept) {
  std::ofstream(file) << "my notes, not a flash image\n";
  hm2::HostMot2Card card;
  EXPECT_THROW(server::Lbp16Card(card, identity()), std::runtime_error);
  std::vector<std::uint8_t> probe(2 * 1024 * 1024);
  const auto r = server::loadFlashFile(file, probe);
  EXPECT_EQ(r.status, server::FlashFileLoad::Status::Refused);
  EXPECT_NE(r.message.find(file.string()), std::string::npos);
  std::ifstream in(file);
  std::string text;
  std::getline(in, text);
  EXPECT_EQ(text, "my notes, not a flash image");
  // An image with a wrong CRC is reported and starts blank.
  std::vector<std::uint8_t> image(probe.size(), 0);
  ASSERT_EQ(server::saveFlashFile(file, image), "");
  {
    std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(100);
    f.put('X');
  }
  EXPECT_EQ(server::loadFlashFile(file, probe).status, server::FlashFileLoad::Status::Corrupt);
  server::Lbp16Card blank(card, identity());
  EXPECT_EQ(readWord(blank, 0), 0xFFFFFFFFU);
}

}  // namespace
