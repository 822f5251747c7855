// The real-time paths do no heap allocation (docs/README.md#engineering-standards): the host cycle
// and the per-datagram server path, counted with a global operator new.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "hostmot2/card.hpp"
#include "lbpkit/encoders.hpp"
#include "sim_card/sim_transport.hpp"
#include "lbpkit/sserial.hpp"
#include "lbp16/lbp16_card.hpp"
#include "lbpkit/lbp16_transport.hpp"
#include "lossy_udp_card.hpp"
#include "running_card.hpp"

namespace {
std::atomic<std::uint64_t> gAllocations{0};
// This thread's own: a test with a server thread counts only the host's.
thread_local std::uint64_t tAllocations = 0;
}  // namespace

void* operator new(std::size_t n) {
  ++gAllocations;
  ++tAllocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
// Not inlined: GCC would see free() on what it takes for a builtin
// operator new's pointer (std::thread's state) and warn of a mismatch.
[[gnu::noinline]] void operator delete(void* p) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace {

using namespace std::chrono_literals;

TEST(RealTime, TheHostCycleDoesNotAllocate) {
  testing_host::RunningCard rc;
  auto& t = rc.t;
  auto& ss = rc.ss;
  lbpkit::MuxedEncoders enc(t, rc.info);
  enc.initialize();
  const auto out = ss.find(0, "output");
  const auto a0 = ss.find(1, "analogout0");
  t.card().encoders().setVelocity(0, 1000, hm2::SimTime{t.now()});
  for (int i = 0; i < 10; ++i) ss.cycle();  // warm up
  const auto before = gAllocations.load();
  for (int i = 0; i < 1000; ++i) {
    ss.setRaw(out, static_cast<std::uint64_t>(i) & 0xFFFF);
    ss.set(a0, (i % 20) - 10.0);
    ss.queueOutputs();
    enc.queue();
    (void)t.tryFlush();
    ASSERT_TRUE(ss.collectInputs().ok);
    enc.update();
    t.sleep(1ms);
  }
  EXPECT_EQ(gAllocations.load() - before, 0U);
}

// Lost replies (the outputs' exchange, or a poll) take the status path.
TEST(RealTime, ACycleThatLosesItsReplyDoesNotAllocate) {
  testing_host::RunningCard rc;
  auto& t = rc.t;
  auto& ss = rc.ss;
  lbpkit::MuxedEncoders enc(t, rc.info);
  enc.initialize();
  for (int i = 0; i < 10; ++i) ss.cycle();  // warm up
  const auto before = gAllocations.load();
  unsigned lost = 0;
  for (int i = 0; i < 1000; ++i) {
    if (i % 10 == 0) t.dropNextReplies(1 + static_cast<unsigned>(i % 20 == 0));
    ss.queueOutputs();
    enc.queue();
    (void)t.tryFlush();
    if (ss.collectInputs().replyLost) ++lost;
    enc.update();
    t.sleep(1ms);
  }
  EXPECT_EQ(gAllocations.load() - before, 0U);
  EXPECT_EQ(lost, 100U);
  EXPECT_EQ(t.linkCounters().lostReplies, 150U);
}

// The same over real UDP: lost and late replies, discarded leftovers.
TEST(RealTime, TheUdpCycleThatLosesItsReplyDoesNotAllocate) {
  testing_net::LossyUdpCard card;
  lbpkit::Lbp16Transport t("127.0.0.1", card.port());
  t.setCycleTimeout(10ms);
  const auto info = lbpkit::readCardInfo(t);
  lbpkit::SmartSerial ss(t, info, testing_host::channels(0x03));
  ss.discover(0x03);
  ss.startNormal();
  lbpkit::MuxedEncoders enc(t, info);
  enc.initialize();
  for (int i = 0; i < 10; ++i) ss.cycle();  // warm up
  const auto before = tAllocations;
  for (int i = 0; i < 300; ++i) {
    if (i % 50 == 10) card.dropNextReplies(1);
    if (i % 50 == 30) card.delayNextReplies(1, 25ms);
    ss.queueOutputs();
    enc.queue();
    (void)t.tryFlush();
    (void)ss.collectInputs();
    enc.update();
    t.sleep(1ms);
  }
  EXPECT_EQ(tAllocations - before, 0U);
  EXPECT_GE(t.linkCounters().lostReplies, 6U);
  EXPECT_GE(t.linkCounters().discarded, 1U);
  ss.stopAll();
}

TEST(RealTime, TheLbp16DatagramPathDoesNotAllocate) {
  hm2::HostMot2Card card;
  net::Lbp16Card lbp16(card, {});
  // hm2_eth-like traffic: a write datagram (outputs, DOIT, watchdog pet,
  // counter) and a read request (status, encoders, SSerial, counters).
  const std::uint8_t write[] = {0x81, 0xC2, 0x00, 0x5A, 0x01, 0x09, 0x00, 0x00,  // SSerial START 0x903
                                0x81, 0xC2, 0x00, 0x0E, 0x00, 0x00, 0x00, 0x5A,  // watchdog pet
                                0x82, 0xD1, 0x14, 0x00, 0x01, 0x00, 0x00, 0x00};
  const std::uint8_t doit[] = {0x81, 0xC2, 0x00, 0x5A, 0x03, 0x10, 0x00, 0x00};
  const std::uint8_t read[] = {0x82, 0x42, 0x00, 0x10, 0x81, 0x42, 0x00, 0x0D, 0x81, 0x42, 0x00, 0x38,
                               0x86, 0x42, 0x00, 0x35, 0x86, 0x42, 0x00, 0x36, 0x81, 0x42, 0x00, 0x5A,
                               0x81, 0x42, 0x00, 0x5B, 0x81, 0x42, 0x00, 0x5C, 0x81, 0x42, 0x00, 0x5D,
                               0x01, 0x59, 0x08, 0x00, 0x84, 0x51, 0x10, 0x00};
  std::uint8_t reply[net::Lbp16Card::kMaxDatagram];
  hm2::SimTime now{0};
  lbp16.handle(write, reply, now);
  now += 50ms;  // START done, chattering
  const auto before = gAllocations.load();
  for (int i = 0; i < 1000; ++i) {
    now += 1ms;
    lbp16.handle(doit, reply, now);
    ASSERT_GT(lbp16.handle(read, reply, now + 500us), 0U);
  }
  EXPECT_EQ(gAllocations.load() - before, 0U);
}

}  // namespace
