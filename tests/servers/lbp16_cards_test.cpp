// SPDX-License-Identifier: MIT
// Each card's LBP16 face (docs/cards.md#lbp16-per-card): the flash as the
// card's catalogue entry has it, and the FPGA reload through space 6's
// configuration register (0x1E) as its family takes it (mesaflash lbp16.c
// lbp16_board_reload: Xilinx ICAP words, the Efinix configuration register).
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "hostmot2/card.hpp"
#include "lbp16/lbp16_card.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace server = lbpkit::server;

namespace {

using Bytes = std::vector<std::uint8_t>;
using server::lbp16::Command;

struct Face {
  hm2::HostMot2Card card;
  server::Lbp16Card lbp16;
  hm2::SimTime now{0};
  explicit Face(const char* name) : card(options(name)), lbp16(card, server::Lbp16Card::Identity{}) {}
  static hm2::HostMot2Card::Options options(const char* name) {
    hm2::HostMot2Card::Options o;
    o.card = hm2::cards::find(name);
    return o;
  }
  static void put16(Bytes& d, std::uint16_t w) {
    d.push_back(static_cast<std::uint8_t>(w));
    d.push_back(static_cast<std::uint8_t>(w >> 8));
  }
  // One 16-bit write to space 6 at `address`, as mesaflash's packets are.
  static void config(Bytes& d, std::uint16_t value, std::uint16_t address = 0x1E) {
    put16(d, Command{true, true, false, 6, 2, false, 1}.encode());
    put16(d, address);
    put16(d, value);
  }
  Bytes send(const Bytes& d) {
    std::array<std::uint8_t, server::Lbp16Card::kMaxDatagram> reply{};
    now += hm2::SimTime{100'000};
    const auto n = lbp16.handle(d, reply, now);
    return Bytes(reply.begin(), reply.begin() + static_cast<std::ptrdiff_t>(n));
  }
  // IOPort output invert (0x1400): a plain register a reload clears.
  void mark() { card.write32(0x1400, 5, now); }
  bool marked() { return card.read32(0x1400, now) == 5; }
};

TEST(Lbp16Cards, TheFlashIsTheCardsPart) {
  for (const char* name : {"7I92", "7I92T", "7I96S", "7I80HD-25"}) {
    SCOPED_TRACE(name);
    Face f(name);
    const auto& part = f.card.description().lbp16;
    EXPECT_EQ(f.lbp16.flash().size(), part.flashBytes);
    Bytes d;
    Face::put16(d, Command{false, true, false, 3, 4, false, 1}.encode());  // the ID register
    Face::put16(d, 8);
    Face::put16(d, Command{false, true, true, 3, 2, true, 2}.encode());  // info area: cookie, size word,
    Face::put16(d, 2);                                                    // ranges
    const auto r = f.send(d);
    ASSERT_EQ(r.size(), 8U);
    EXPECT_EQ(r[0], 0x14);  // mesaflash's 16 Mbit size code
    EXPECT_EQ(r[6] & 0x3F, 21);  // 2^21 bytes
  }
  EXPECT_EQ(hm2::cards::find("7I96S")->lbp16.family, hm2::cards::FpgaFamily::Efinix);
  EXPECT_EQ(hm2::cards::find("7I92T")->lbp16.family, hm2::cards::FpgaFamily::Efinix);
  EXPECT_EQ(hm2::cards::find("7I92")->lbp16.family, hm2::cards::FpgaFamily::Xilinx);
  EXPECT_EQ(hm2::cards::find("7I80HD-25")->lbp16.family, hm2::cards::FpgaFamily::Xilinx);
}

TEST(Lbp16Cards, AXilinxCardReloadsOnIcapIprog) {
  Face f("7I92");
  f.mark();
  Bytes d;
  Face::config(d, 0x000E);  // IPROG alone is data, not a command
  Face::config(d, 0xAA99);
  Face::config(d, 0x5566);
  Face::config(d, 0x000C);  // the Efinix words mean nothing here
  f.send(d);
  EXPECT_TRUE(f.marked());
  EXPECT_EQ(f.lbp16.counters().reloads, 0U);
  d.clear();
  Face::config(d, 0x30A1);  // write one word to the command register...
  Face::config(d, 0x000E);  // ...IPROG
  Face::config(d, 0x1234, 0x18);  // after the reload: never parsed
  f.send(d);
  EXPECT_FALSE(f.marked());
  EXPECT_EQ(f.lbp16.counters().reloads, 1U);
  Bytes scratch;
  Face::put16(scratch, Command{false, true, false, 6, 2, false, 1}.encode());
  Face::put16(scratch, 0x18);
  EXPECT_EQ(f.send(scratch), (Bytes{0, 0}));  // space 6's scratch register: cleared, not 0x1234
}

TEST(Lbp16Cards, AnEfinixCardReloadsOnEnableAndStart) {
  Face f("7I96S");
  f.mark();
  Bytes d;
  Face::config(d, 0x0005);  // image 1, enable: not yet
  Face::config(d, 0xAA99);  // Xilinx sync words and a command-register
  Face::config(d, 0x5566);  // write lack the start bit with the enable
  Face::config(d, 0x30A1);
  f.send(d);
  EXPECT_TRUE(f.marked());
  // mesaflash's datagram: enable, then enable + start, then a tail it never
  // filled in (here a HostMot2 write that must not happen).
  d.clear();
  Face::config(d, 0x0005);
  Face::config(d, 0x000D);
  Face::put16(d, Command{true, true, false, 0, 4, false, 1}.encode());
  Face::put16(d, 0x1400);
  Face::put16(d, 7);
  Face::put16(d, 0);
  f.send(d);
  EXPECT_EQ(f.lbp16.counters().reloads, 1U);
  EXPECT_EQ(f.card.read32(0x1400, f.now), 0U);
}

}  // namespace
