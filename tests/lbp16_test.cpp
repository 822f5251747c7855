// The virtual card's LBP16 face, datagram by datagram.
#include <gtest/gtest.h>

#include <vector>

#include "hostmot2/card.hpp"
#include "lbp16/lbp16_card.hpp"

namespace {

using Bytes = std::vector<std::uint8_t>;
using net::lbp16::Command;

struct Lbp16Test : ::testing::Test {
  hm2::HostMot2Card card;
  net::Lbp16Card lbp16{card, net::Lbp16Card::Identity{}};
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
    std::array<std::uint8_t, net::Lbp16Card::kMaxDatagram> reply{};
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
  EXPECT_EQ(net::lbp16::hm2Read(1), 0x4281);                          // read HM2 1x32 auto-inc
  EXPECT_EQ(net::lbp16::hm2Write(1), 0xC281);                         // hm2_eth's watchdog pet
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
  cmd(d, {false, true, false, 0, 8, false, 1}, 0x0100);  // one 64-bit read
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
  EXPECT_EQ(std::string(a.begin() + 8, a.begin() + 16).c_str(), std::string("SPIFlash"));
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
  // Unknown space, unsupported width, past the end: zeros, full length, counted.
  Bytes u;
  cmd(u, {false, true, false, 5, 2, true, 4}, 0);
  cmd(u, {false, true, false, 0, 2, true, 2}, 0x0100);
  cmd(u, {false, true, false, 7, 2, true, 4}, 0x1E);
  const auto r = send(u);
  ASSERT_EQ(r.size(), 8U + 4U + 8U);
  for (std::size_t i = 0; i < 12; ++i) EXPECT_EQ(r[i], 0) << i;
  EXPECT_GE(lbp16.counters().memoryErrors, 3U);
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
  // Oversized: refused whole.
  EXPECT_TRUE(send(Bytes(2000, 0x42)).empty());
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
  EXPECT_LE(r.size(), net::Lbp16Card::kMaxDatagram);
  EXPECT_EQ(r.size() % 508, 0U);  // whole commands only
  EXPECT_GE(lbp16.counters().parseErrors, 1U);
}

}  // namespace
