// SPDX-License-Identifier: MIT
// The LBP parser against a plain memory, including every worked example of
// the manual's LBP chapter, byte for byte.
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "lbp/protocol.hpp"
#include "lbp/parser.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace lbp = lbpkit::model::lbp;

namespace {

using Bytes = std::vector<std::uint8_t>;
using lbp::SimTime;
using namespace std::chrono_literals;

struct MemoryTarget : lbp::Target {
  std::array<std::uint8_t, 65536> mem{};
  std::uint16_t readOnlyFrom = 0xF000;  // 0xF000.. is ROM
  int begins = 0, ends = 0, resets = 0;
  std::uint8_t readMemory(std::uint16_t a) override { return mem[a]; }
  bool writeMemory(std::uint16_t a, std::uint8_t v) override {
    if (a >= readOnlyFrom) return false;
    mem[a] = v;
    return true;
  }
  std::optional<std::uint8_t> readLocal(std::uint8_t c) override {
    if (c >= 0xD0 && c <= 0xD3) return "7I77"[c - 0xD0];
    return std::nullopt;
  }
  bool writeLocal(std::uint8_t, std::uint8_t) override { return false; }
  std::optional<RpcSizes> specialRpc(std::uint8_t c) override {
    if (c == lbp::special_rpc::kProcessData) return RpcSizes{2, 3};
    return std::nullopt;
  }
  void runSpecialRpc(std::uint8_t, std::span<const std::uint8_t> in, std::span<std::uint8_t> out) override {
    out[0] = 0x00;  // fault byte
    out[1] = static_cast<std::uint8_t>(in[0] ^ 0xFF);
    out[2] = static_cast<std::uint8_t>(in[1] ^ 0xFF);
  }
  void beginCommand(SimTime) override { ++begins; }
  void endCommand(SimTime) override { ++ends; }
  void resetProcessor() override { ++resets; }
};

class ParserTest : public ::testing::Test {
 protected:
  MemoryTarget target;
  lbp::Parser parser{target, lbp::ParserConfig{}};  // 115200 baud, 25.5 character timeout
  SimTime now{0};
  const SimTime ch = lbp::characterTime(115200);

  // Characters back to back, then a little idle time.
  Bytes raw(const Bytes& bytes) {
    Bytes reply;
    for (auto b : bytes) {
      now += ch;
      auto r = parser.receive(b, now);
      reply.insert(reply.end(), r.begin(), r.end());
    }
    now += ch;
    return reply;
  }
  static Bytes crc(Bytes b) {
    b.push_back(lbp::crc8(b));
    return b;
  }
  Bytes send(const Bytes& b) { return raw(crc(b)); }
  void gap() { now += 30 * ch; }
};

TEST_F(ParserTest, HeaderEncodingMatchesTheManualBitTables) {
  EXPECT_EQ(lbp::writeHeader(4, true, true), 0x6E);   // LBPWrite: 2 add 4 data, AutoInc
  EXPECT_EQ(lbp::writeHeader(2, false, false), 0x61);  // LBPWrite: 0 add 2 data
  EXPECT_EQ(lbp::readHeader(8, true), 0x47);           // LBPRead: 2 add 8 data
  EXPECT_EQ(lbp::writeHeader(2, true), 0x65);          // RPC example command 1
  EXPECT_EQ(lbp::readHeader(2, true), 0x45);           // RPC example command 2
  const auto d = lbp::DataCommand::decode(0x6E);
  EXPECT_TRUE(d.write);
  EXPECT_TRUE(d.autoInc);
  EXPECT_TRUE(d.hasAddress);
  EXPECT_EQ(d.dataSize, 4);
}

TEST_F(ParserTest, ManualExampleCommandsByteForByte) {
  ASSERT_EQ(send({0xEA, 0x01}), Bytes{0x00});  // RPCMEM on: 0x010.. is in the RPC table
  // "Write 4 bytes (0xAA, 0xBB, 0xCC, 0xDD) to 0x010..0x013 with AutoInc".
  const Bytes write4{0x6E, 0x10, 0x00, 0xAA, 0xBB, 0xCC, 0xDD};
  EXPECT_EQ(raw(crc(write4)), Bytes{0x00});  // no read data: the lone CRC 0x00
  EXPECT_EQ(parser.addressPointer(), 0x014);
  // "Write 2 more bytes (0xEE, 0xFF) at 0x014 and 0x015" (no address: pointer).
  EXPECT_EQ(send({0x61, 0xEE, 0xFF}), Bytes{0x00});
  EXPECT_EQ(parser.addressPointer(), 0x014);  // AI clear: unchanged
  EXPECT_EQ(target.mem[0x014], 0xEE);
  EXPECT_EQ(target.mem[0x015], 0xFF);
  // "Read 8 bytes at 0x010..0x017".
  const Bytes reply = send({0x47, 0x10, 0x00});
  Bytes expected{0xAA, 0xBB, 0xCC, 0xDD, 0xEE, 0xFF, 0x00, 0x00};
  expected.push_back(lbp::crc8(expected));
  EXPECT_EQ(reply, expected);
}

TEST_F(ParserTest, ManualRpcExampleAtRpc5) {
  ASSERT_EQ(send({0xEA, 0x01}), Bytes{0x00});
  // The stored list at 0x0028: write 2 bytes at 0x10 (data from the stream),
  // read 2 bytes at 0x12, terminator.
  const Bytes list{0x65, 0x10, 0x00, 0x45, 0x12, 0x00, 0x00};
  Bytes cmd{lbp::writeHeader(8, true), 0x28, 0x00};
  cmd.insert(cmd.end(), list.begin(), list.end());
  cmd.push_back(0x00);
  ASSERT_EQ(send(cmd), Bytes{0x00});
  target.mem[0x12] = 0x34;
  target.mem[0x13] = 0x56;
  // "The data stream for this RPC would consist of these 3 bytes": 0x85 0x55 0xCC.
  EXPECT_EQ(lbp::kRpcCommandBase | 5, 0x85);
  const Bytes reply = send({0x85, 0x55, 0xCC});
  EXPECT_EQ(reply, (Bytes{0x34, 0x56, lbp::crc8(Bytes{0x34, 0x56})}));
  EXPECT_EQ(target.mem[0x10], 0x55);
  EXPECT_EQ(target.mem[0x11], 0xCC);
}

TEST_F(ParserTest, RpcWithItsOwnDataUsesTheStoredBytes) {
  ASSERT_EQ(send({0xEA, 0x01}), Bytes{0x00});
  // RPC 2 at 0x10: write 2 bytes at 0x300 carried in the list (RID), read them back.
  const Bytes list{0x75, 0x00, 0x03, 0x12, 0x34, 0x45, 0x00, 0x03, 0x00};
  Bytes cmd{lbp::writeHeader(8, true), 0x10, 0x00};
  cmd.insert(cmd.end(), list.begin(), list.begin() + 8);
  ASSERT_EQ(send(cmd), Bytes{0x00});
  ASSERT_EQ(send({lbp::writeHeader(1, true), 0x18, 0x00, list[8]}), Bytes{0x00});  // terminator
  EXPECT_EQ(send({0x82}), (Bytes{0x12, 0x34, lbp::crc8(Bytes{0x12, 0x34})}));
}

TEST_F(ParserTest, RpcTableIsProtectedUnlessRpcMemIsSet) {
  EXPECT_EQ(send({lbp::writeHeader(1, true), 0x10, 0x00, 0x99}), Bytes{0x00});
  EXPECT_EQ(target.mem[0x10], 0x00);
  EXPECT_TRUE(parser.status() & lbp::status::kInvalidWrite);
  EXPECT_EQ(send({0xCA}), (Bytes{0x00, 0x00}));  // RPCMEM reads clear
}

TEST_F(ParserTest, WriteToReadOnlyMemoryIsAnInvalidWrite) {
  EXPECT_EQ(send({lbp::writeHeader(2, true), 0x00, 0xF0, 1, 2}), Bytes{0x00});
  EXPECT_EQ(target.mem[0xF000], 0);
  EXPECT_EQ(send({0xC1}), (Bytes{lbp::status::kInvalidWrite, lbp::crc8(Bytes{lbp::status::kInvalidWrite})}));
  EXPECT_EQ(send({0xE1, 0x00}), Bytes{0x00});  // 0 clears the errors
  EXPECT_EQ(parser.status(), 0);
}

TEST_F(ParserTest, LocalRegistersOfTheProtocol) {
  auto one = [&](std::uint8_t c) { return send({c}).at(0); };
  EXPECT_EQ(one(lbp::local_read::kCookie), 0x5A);
  EXPECT_EQ(one(lbp::local_read::kRpcPitch), 8);
  EXPECT_EQ(one(lbp::local_read::kRpcSizeLow), 0x00);
  EXPECT_EQ(one(lbp::local_read::kRpcSizeHigh), 0x02);
  EXPECT_EQ(one(lbp::local_read::kCrcEnable), 0xFF);
  EXPECT_EQ(one(lbp::local_read::kCommandTimeout), 255);
  EXPECT_EQ(one(0xD0), '7');
  EXPECT_EQ(one(0xD3), '7');
  EXPECT_EQ(one(0xC4), 0x00);  // reserved: 0, and the parser stays in step
  // The address pointer: set low/high, add, read back.
  ASSERT_EQ(send({0xF8, 0x34}), Bytes{0x00});
  ASSERT_EQ(send({0xF9, 0x12}), Bytes{0x00});
  ASSERT_EQ(send({0xFA, 0x10}), Bytes{0x00});
  EXPECT_EQ(one(0xD8), 0x44);
  EXPECT_EQ(one(0xD9), 0x12);
  // CRCs are always on for the 7I77: disabling is ignored.
  ASSERT_EQ(send({0xE2, 0x00}), Bytes{0x00});
  EXPECT_EQ(one(lbp::local_read::kCrcEnable), 0xFF);
  // Writing a reserved local is a write to a protected area.
  EXPECT_EQ(send({0xE4, 0x01}), Bytes{0x00});
  EXPECT_TRUE(parser.status() & lbp::status::kInvalidWrite);
}

TEST_F(ParserTest, AutoIncrementWalksTheAddressPointer) {
  ASSERT_EQ(send({lbp::writeHeader(2, true, true), 0x00, 0x10, 0x01, 0x02}), Bytes{0x00});
  ASSERT_EQ(send({lbp::writeHeader(2, false, true), 0x03, 0x04}), Bytes{0x00});
  EXPECT_EQ(parser.addressPointer(), 0x1004);
  EXPECT_EQ((Bytes{target.mem[0x1000], target.mem[0x1001], target.mem[0x1002], target.mem[0x1003]}),
            (Bytes{1, 2, 3, 4}));
  ASSERT_EQ(send({lbp::readHeader(1, true, true), 0x00, 0x10}).at(0), 1);
  EXPECT_EQ(send({lbp::readHeader(1, false, true)}).at(0), 2);
  EXPECT_EQ(send({lbp::readHeader(2, false, false)}).at(1), 4);
}

TEST_F(ParserTest, BadCrcIsCountedNotExecutedNotAnswered) {
  Bytes cmd = crc({lbp::writeHeader(1, true), 0x00, 0x10, 0x77});
  cmd.back() ^= 0x01;
  EXPECT_TRUE(raw(cmd).empty());
  EXPECT_EQ(target.mem[0x1000], 0);
  EXPECT_EQ(parser.crcErrorCount(), 1);
  EXPECT_TRUE(parser.status() & lbp::status::kCrcError);
  EXPECT_EQ(target.begins, 0);
  // The next command is parsed normally.
  EXPECT_EQ(send({0xC3}), (Bytes{0x01, lbp::crc8(Bytes{0x01})}));
  ASSERT_EQ(send({0xE3, 0x00}), Bytes{0x00});
  EXPECT_EQ(parser.crcErrorCount(), 0);
}

TEST_F(ParserTest, TruncatedCommandTimesOutAtTheGapAndTheNextCommandWorks) {
  EXPECT_TRUE(raw({lbp::writeHeader(4, true), 0x00, 0x10, 0xAA}).empty());
  EXPECT_TRUE(parser.midCommand());
  gap();
  EXPECT_EQ(send({0xDF}), (Bytes{0x5A, lbp::crc8(Bytes{0x5A})}));
  EXPECT_TRUE(parser.status() & lbp::status::kCommandTimeout);
  EXPECT_EQ(target.mem[0x1000], 0);
}

TEST_F(ParserTest, GapShorterThanTheTimeoutDoesNotSplitACommand) {
  const Bytes cmd = crc({0xDF});
  now += ch;
  EXPECT_TRUE(parser.receive(cmd[0], now).empty());
  now += ch + 25 * ch;  // 25 idle characters < 25.5
  EXPECT_EQ(parser.receive(cmd[1], now).size(), 2U);
}

TEST_F(ParserTest, OperateModeTimeoutIsFourCharacters) {
  ASSERT_EQ(send({0xEB, 40}), Bytes{0x00});  // what SSLBP writes at START
  const Bytes cmd = crc({0xDF});
  now += ch;
  EXPECT_TRUE(parser.receive(cmd[0], now).empty());
  now += ch + 5 * ch;  // 5 idle characters > 4: the header was dropped
  EXPECT_TRUE(parser.receive(cmd[1], now).empty());
  EXPECT_TRUE(parser.status() & lbp::status::kCommandTimeout);
}

TEST_F(ParserTest, GarbageHeaderIsSkippedUntilAGap) {
  EXPECT_TRUE(raw({0x00, 0x17, 0xDF}).empty());  // 0x00..0x3F is no command
  gap();
  EXPECT_EQ(send({0xDF}).at(0), 0x5A);
}

TEST_F(ParserTest, RpcNeedingMoreThanTheBufferIsABufferOverflow) {
  ASSERT_EQ(send({0xEA, 0x01}), Bytes{0x00});
  // RPC 0: 64 stored "write 8 bytes from the stream" headers = 512 stream bytes.
  for (std::uint16_t a = 0; a < 64; a += 8) {
    ASSERT_EQ(send({lbp::writeHeader(8, true), static_cast<std::uint8_t>(a), 0x00, 0x63, 0x63, 0x63, 0x63, 0x63,
                    0x63, 0x63, 0x63}),
              Bytes{0x00});
  }
  EXPECT_TRUE(raw({0x80, 1, 2, 3, 4}).empty());
  EXPECT_TRUE(parser.status() & lbp::status::kBufferOverflow);
  gap();
  EXPECT_EQ(send({0xDF}).at(0), 0x5A);
}

TEST_F(ParserTest, SpecialRpcCarriesItsDataBothWays) {
  EXPECT_EQ(send({lbp::special_rpc::kProcessData, 0x0F, 0xF0}),
            (Bytes{0x00, 0xF0, 0x0F, lbp::crc8(Bytes{0x00, 0xF0, 0x0F})}));
}

TEST_F(ParserTest, ResetCommands) {
  EXPECT_EQ(send({0xFE, 0x11}), Bytes{0x00});  // wrong key: nothing
  EXPECT_EQ(target.resets, 0);
  EXPECT_TRUE(send({0xFE, 0x5A}).empty());  // the processor restarts: no answer at all
  EXPECT_EQ(target.resets, 1);
  // A run of 0xFF completes any half-received command (which then fails its
  // CRC) and leaves the parser idle: each further 0xFF is a parser reset.
  EXPECT_TRUE(raw({lbp::writeHeader(4, true), 0x00}).empty());
  EXPECT_TRUE(raw(Bytes(16, 0xFF)).empty());
  EXPECT_FALSE(parser.midCommand());
  EXPECT_EQ(target.mem[0], 0);
  EXPECT_EQ(send({0xDF}).at(0), 0x5A);
}

// LOCAL LBP WRITE COMMANDS: 0xFE with 0x5A resets the processor. It
// restarts instead of answering: no data and no CRC byte, and the next
// command is parsed from its first byte.
TEST_F(ParserTest, AProcessorResetAnswersNothingAndTheNextCommandWorks) {
  const int endsBefore = target.ends;
  EXPECT_TRUE(raw(crc({0xFE, lbp::kResetKey})).empty());
  EXPECT_EQ(target.resets, 1);
  EXPECT_EQ(target.ends, endsBefore);  // not a command that completed: the processor restarted
  EXPECT_FALSE(parser.midCommand());
  EXPECT_EQ(send({lbp::local_read::kCookie}), (Bytes{0x5A, lbp::crc8(Bytes{0x5A})}));
}

// LOCAL LBP READ COMMANDS: CRC enable (0xC2) and RPCMEM (0xCA) are flags,
// read back as the firmware stores true: 0xFF (LBP.INC), false 0x00.
TEST_F(ParserTest, FlagsReadBackAsTheFirmwareStoresTrue) {
  auto one = [&](std::uint8_t c) { return send({c}).at(0); };
  EXPECT_EQ(one(lbp::local_read::kCrcEnable), 0xFF);
  EXPECT_EQ(one(lbp::local_read::kRpcMemEnable), 0x00);
  ASSERT_EQ(send({lbp::local_write::kRpcMemEnable, 0x01}), Bytes{0x00});  // any non-zero sets it
  EXPECT_EQ(one(lbp::local_read::kRpcMemEnable), 0xFF);
  ASSERT_EQ(send({lbp::local_write::kRpcMemEnable, 0x00}), Bytes{0x00});
  EXPECT_EQ(one(lbp::local_read::kRpcMemEnable), 0x00);
}

// LBP DATA READ/WRITE COMMAND: RID is "RPC only, ignored for non RPC
// commands". A write sent on its own with RID set carries its data after the
// address like any write: it is executed and answered, not taken as having
// no data (which made its first data byte the CRC, and the command fail).
TEST_F(ParserTest, RidOnADirectCommandIsIgnored) {
  const std::uint8_t rid = lbp::DataCommand::kRpcIncludesData;
  const std::uint8_t write2 = lbp::writeHeader(2, true) | rid;  // 0x75
  ASSERT_EQ(write2, 0x75);
  EXPECT_EQ(send({write2, 0x00, 0x03, 0x12, 0x34}), Bytes{0x00});
  EXPECT_EQ(target.mem[0x300], 0x12);
  EXPECT_EQ(target.mem[0x301], 0x34);
  EXPECT_EQ(parser.crcErrorCount(), 0);
  EXPECT_EQ(parser.status() & lbp::status::kCrcError, 0);
  // Without an address (the pointer, now 0x300) and on a read alike.
  EXPECT_EQ(send({static_cast<std::uint8_t>(lbp::writeHeader(1, false) | rid), 0x56}), Bytes{0x00});
  EXPECT_EQ(target.mem[0x300], 0x56);
  EXPECT_EQ(send({static_cast<std::uint8_t>(lbp::readHeader(2, true) | rid), 0x00, 0x03}),
            (Bytes{0x56, 0x34, lbp::crc8(Bytes{0x56, 0x34})}));
  // Inside an RPC list RID still means the data is stored with the command.
  ASSERT_EQ(send({0xEA, 0x01}), Bytes{0x00});
  const Bytes list{write2, 0x10, 0x03, 0xAB, 0xCD, 0x00};
  Bytes store{lbp::writeHeader(8, true), 0x08, 0x00};
  store.insert(store.end(), list.begin(), list.end());
  store.push_back(0);
  store.push_back(0);
  ASSERT_EQ(send(store), Bytes{0x00});
  EXPECT_EQ(send({0x81}), Bytes{0x00});  // RPC 1: no stream data
  EXPECT_EQ(target.mem[0x310], 0xAB);
  EXPECT_EQ(target.mem[0x311], 0xCD);
}

TEST_F(ParserTest, AnRpcThatRewritesItsOwnListConsumesOnlyWhatArrived) {
  ASSERT_EQ(send({0xEA, 0x01}), Bytes{0x00});
  // RPC 0: "write 1 byte at 0x0003 from the stream"; byte 3 is where the list
  // would continue, and the stream byte puts a 0x6B (8-byte write) there.
  ASSERT_EQ(send({lbp::writeHeader(4, true), 0x00, 0x00, 0x64, 0x03, 0x00, 0x00}), Bytes{0x00});
  EXPECT_EQ(send({0x80, 0x6B}), Bytes{0x00});
  EXPECT_EQ(target.mem[3], 0x6B);
  EXPECT_FALSE(parser.midCommand());
  EXPECT_EQ(send({0xDF}).at(0), 0x5A);
}

TEST_F(ParserTest, ALongestAnswerStillEndsWithItsCrc) {
  ASSERT_EQ(send({0xEA, 0x01}), Bytes{0x00});
  // RPC 0 fills the table with "read 8 bytes" (0x43): 511 reads, capped at
  // the 4096-byte answer, then the CRC.
  for (std::uint16_t a = 0; a < 0x200; a += 8)
    ASSERT_EQ(send({lbp::writeHeader(8, true), static_cast<std::uint8_t>(a), static_cast<std::uint8_t>(a >> 8), 0x43,
                    0x43, 0x43, 0x43, 0x43, 0x43, 0x43, 0x43}),
              Bytes{0x00});
  const Bytes r = send({0x80});
  ASSERT_EQ(r.size(), lbp::Parser::kMaxResponse + 1);
  EXPECT_EQ(lbp::crc8(r), 0);
}

TEST_F(ParserTest, RandomBytesNeverBreakTheParser) {
  std::uint32_t x = 12345;
  for (int i = 0; i < 200000; ++i) {
    x = x * 1664525U + 1013904223U;
    now += ch * ((x >> 28) == 0 ? 40 : 1);
    (void)parser.receive(static_cast<std::uint8_t>(x >> 16), now);
  }
  gap();
  ASSERT_EQ(send({0xE1, 0x00}), Bytes{0x00});
  EXPECT_EQ(send({0xDF}).at(0), 0x5A);
}

}  // namespace
