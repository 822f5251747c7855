// SPDX-License-Identifier: MIT
// A lost or late reply in the real-time cycle is a status the caller sees,
// with counters, never an exception; the cycle after it recovers. Over the
// in-process card (SimTransport's lost-reply hook) and over real UDP (the
// virtual card in a thread that drops or delays replies).
#include <gtest/gtest.h>

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <thread>

#include "lbpkit/encoders.hpp"
#include "lbpkit/error.hpp"
#include "lbpkit/lbp16_transport.hpp"
#include "lbpkit/sserial.hpp"
#include "lbpkit/wire/hostmot2.hpp"
#include "support/lossy_udp_card.hpp"
#include "support/running_card.hpp"
#include "support/wait.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

namespace {

using namespace std::chrono_literals;

TEST(CycleStatus, ALostReplyKeepsTheLastInputsAndTheNextCycleRecovers) {
  testing_host::RunningCard rc;
  auto& t = rc.t;
  auto& ss = rc.ss;
  auto& io = t.card().daughtercard(0).fieldIo;
  const auto input = ss.find(0, "input");
  ASSERT_TRUE(input.valid());
  io.setInputVoltage(3, 24.0);
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(ss.cycle().ok) << i;
    t.sleep(1ms);
  }
  ASSERT_EQ(ss.raw(input) & 0xFF, 0x08U);
  EXPECT_EQ(t.linkCounters().lostReplies, 0U);

  // The world changes; the cycle that would bring it loses its reply.
  io.setInputVoltage(3, 0.0);
  io.setInputVoltage(5, 24.0);
  const auto cycles = ss.cycles();
  t.dropNextReplies(1);
  lbpkit::CycleStatus st;
  ASSERT_NO_THROW(st = ss.cycle());
  EXPECT_FALSE(st.ok);
  EXPECT_TRUE(st.replyLost);
  EXPECT_EQ(st.failedMask, 0U);
  EXPECT_EQ(t.linkCounters().lostReplies, 1U);
  EXPECT_EQ(ss.lostCycles(), 1U);
  EXPECT_EQ(ss.cycles(), cycles);
  // The card had the new inputs in its registers; the driver did not take them.
  const auto inCard = t.card().read32(ss.registers().interface(0, 0), hm2::SimTime{t.now()});
  EXPECT_EQ(inCard & 0xFF, 0x20U);
  EXPECT_EQ(ss.raw(input) & 0xFF, 0x08U);

  t.sleep(1ms);
  st = ss.cycle();
  EXPECT_TRUE(st.ok);
  EXPECT_FALSE(st.replyLost);
  EXPECT_EQ(ss.raw(input) & 0xFF, 0x20U);
  EXPECT_EQ(ss.lostCycles(), 1U);
  EXPECT_EQ(ss.cycles(), cycles + 1);

  // Set-up calls still insist on an answer.
  t.dropNextReplies(1);
  EXPECT_THROW(t.read32(ss.registers().command()), lbpkit::Error);
  EXPECT_EQ(t.linkCounters().lostReplies, 2U);
}

// The outputs' exchange also carries the encoder reads: when its reply is
// lost the encoders must not take the stale registers for a stop.
TEST(CycleStatus, EncodersSkipACycleWithoutFreshData) {
  testing_host::RunningCard rc;
  auto& t = rc.t;
  auto& ss = rc.ss;
  lbpkit::MuxedEncoders enc(t, rc.info);
  enc.initialize();
  t.card().part<hm2::MuxedEncoder>().setVelocity(0, 10000, hm2::SimTime{t.now()});
  auto cycle = [&](bool expectFresh) {
    const auto start = t.now();
    ss.queueOutputs();
    enc.queue();
    const bool flushed = t.tryFlush();
    const auto st = ss.collectInputs();
    const bool fresh = enc.update();
    EXPECT_EQ(flushed, expectFresh);
    EXPECT_EQ(fresh, expectFresh);
    EXPECT_EQ(st.replyLost, !expectFresh);
    EXPECT_EQ(st.failedMask, 0U);
    t.sleep(1ms - std::min<lbpkit::Nanoseconds>(1ms, t.now() - start));
    return st;
  };
  for (int i = 0; i < 300; ++i) cycle(true);
  ASSERT_NEAR(enc.velocity(0), 10000, 100);
  const auto before = enc.counts(0);
  const auto lostBefore = ss.lostCycles();
  t.dropNextReplies(1);
  const auto st = cycle(false);
  EXPECT_FALSE(st.ok);
  EXPECT_EQ(ss.lostCycles(), lostBefore + 1);
  EXPECT_EQ(enc.counts(0), before);               // nothing new known
  EXPECT_NEAR(enc.velocity(0), 10000, 100);       // and not a stop
  cycle(true);
  EXPECT_NEAR(static_cast<double>(enc.counts(0) - before), 20, 3);  // both cycles' counts
  EXPECT_NEAR(enc.velocity(0), 10000, 100);
}

// One cycle over real UDP with a card that loses the reply: a status, not an
// exception, and the cycles after it bring fresh inputs again.
TEST(CycleStatus, OverUdpALostReplyIsAStatusNotAnException) {
  testing_net::LossyUdpCard card;
  lbpkit::Lbp16Transport t("127.0.0.1", card.port());
  t.setCycleTimeout(20ms);
  EXPECT_EQ(t.cycleTimeout(), 20ms);
  const auto info = lbpkit::readCardInfo(t);
  lbpkit::SmartSerial ss(t, info, testing_host::channels(0x03));
  ss.discover(0x03);
  ss.startNormal();
  const auto input = ss.find(0, "input");
  const auto output = ss.find(0, "output");
  ASSERT_TRUE(input.valid() && output.valid());
  auto cycle = [&] {
    const auto st = ss.cycle();
    if (st.failedMask)  // a watchdog that bit while the machine was busy
      for (unsigned s = 0; s < ss.slots(); ++s) ss.recover(s);
    t.sleep(1ms);
    return st;
  };
  for (int ok = 0, i = 0; ok < 5; ++i) {
    ASSERT_LT(i, 1000) << "the card never answered five cycles in a row";
    ok = cycle().ok ? ok + 1 : 0;
  }

  const auto lost = t.linkCounters().lostReplies;
  const auto lostCycles = ss.lostCycles();
  card.dropNextReplies(1);
  lbpkit::CycleStatus st;
  ASSERT_NO_THROW(st = ss.cycle());
  // The card's thread drops the request when it gets to it, which a busy
  // machine may put after the cycle has given up waiting.
  EXPECT_TRUE(test_support::waitFor([&] { return card.dropped() == 1U; }, 5s)) << card.dropped() << " dropped";
  EXPECT_FALSE(st.ok);
  EXPECT_TRUE(st.replyLost);
  EXPECT_GE(t.linkCounters().lostReplies, lost + 1);
  EXPECT_GE(ss.lostCycles(), lostCycles + 1);

  // Recovery: outputs reach the card and come back as inputs (wired).
  ss.setRaw(output, 0x0005);
  bool seen = false;
  for (int i = 0; i < 200 && !seen; ++i) {
    const auto s = cycle();
    seen = s.ok && (ss.raw(input) & 0xFFFF) == 0x0005;
  }
  EXPECT_TRUE(seen);
  ss.stopAll();
}

// A reply that comes after its exchange timed out has the same length as
// the next one's: the sequence tag tells them apart, so every exchange that
// succeeds returns its own data, never the one before.
TEST(CycleStatus, OverUdpALateReplyIsDiscardedNotTakenForTheNext) {
  testing_net::LossyUdpCard card;
  lbpkit::Lbp16Transport t("127.0.0.1", card.port());
  t.setCycleTimeout(30ms);
  const auto info = lbpkit::readCardInfo(t);
  const auto* ioport = info.module(lbpkit::wire::hm2::tag::kIoPort);
  ASSERT_NE(ioport, nullptr);
  // Port 0's open-drain register reads back what was written.
  const auto reg = static_cast<std::uint16_t>(ioport->baseAddress + 3 * ioport->registerStride);
  auto exchange = [&](std::uint32_t k, std::uint32_t& got) {
    t.queueWrite(reg, &k);
    t.queueRead(reg, &got);
    return t.tryFlush();
  };
  std::uint32_t got = 0;
  ASSERT_TRUE(exchange(1000, got));
  ASSERT_EQ(got, 1000U);

  card.delayNextReplies(1, 100ms);
  unsigned lost = 0, fresh = 0;
  for (std::uint32_t k = 1; k < 100 && fresh < 5; ++k) {
    got = 0xFFFFFFFF;
    if (exchange(k, got)) {
      EXPECT_EQ(got, k) << "exchange " << k << " took another exchange's reply";
      ++fresh;
    } else {
      EXPECT_EQ(got, 0xFFFFFFFFU) << "a failed exchange wrote its buffer";
      ++lost;
    }
  }
  EXPECT_EQ(card.delayed(), 1U);
  EXPECT_GE(lost, 1U);
  EXPECT_EQ(fresh, 5U);
  const auto c = t.linkCounters();
  EXPECT_EQ(c.lostReplies, lost);
  EXPECT_GE(c.discarded, 1U);  // the late reply, at least
  EXPECT_EQ(c.sendFailures, 0U);
}

// Nothing listens: the cycle's flush says so and counts it; set-up throws.
TEST(CycleStatus, OverUdpARefusedDatagramIsCountedNotThrown) {
  std::uint16_t port = 0;
  {
    // A port that was free a moment ago.
    const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    ASSERT_GE(fd, 0);
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa), 0);
    socklen_t len = sizeof sa;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&sa), &len);
    port = ntohs(sa.sin_port);
    ::close(fd);
  }
  lbpkit::Lbp16Transport t("127.0.0.1", port);
  t.setCycleTimeout(200ms);
  std::uint32_t v = 7;
  t.queueRead(0x0100, &v);
  bool ok = true;
  ASSERT_NO_THROW(ok = t.tryFlush());
  EXPECT_FALSE(ok);
  EXPECT_EQ(v, 7U);
  const auto c = t.linkCounters();
  EXPECT_EQ(c.sendFailures + c.lostReplies, 1U);
  try {
    t.read32(0x0100);
    FAIL() << "expected an error";
  } catch (const lbpkit::Error& e) {
    EXPECT_NE(std::string(e.what()).find("nothing listens"), std::string::npos) << e.what();
  }
}

}  // namespace
