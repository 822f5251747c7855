// SPDX-License-Identifier: MIT
// The real-time paths do no heap allocation (docs/README.md#engineering-standards): the host cycle
// and the per-datagram server path, counted with a global operator new.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>
#include <vector>

#include "daemon/trace_ring.hpp"
#include "hostmot2/card.hpp"
#include "lbp16/lbp16_card.hpp"
#include "lbpkit/encoders.hpp"
#include "lbpkit/lbp16_transport.hpp"
#include "lbpkit/servo_cycle.hpp"
#include "lbpkit/sserial.hpp"
#include "machine/machine.hpp"
#include "sim_card/sim_transport.hpp"
#include "support/allocation_counter.hpp"
#include "support/lossy_udp_card.hpp"
#include "support/running_card.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace machine = lbpkit::model::machine;
namespace server = lbpkit::server;

using testing_alloc::gAllocations;
using testing_alloc::tAllocations;

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
  t.card().part<hm2::MuxedEncoder>().setVelocity(0, 1000, hm2::SimTime{t.now()});
  for (int i = 0; i < 10; ++i) ss.cycle();  // warm up
  const auto before = gAllocations.load();
  for (int i = 0; i < 1000; ++i) {
    ss.setRaw(out, static_cast<std::uint64_t>(i) & 0xFFFF);
    ss.set(a0, (i % 20) - 10.0);
    ASSERT_TRUE(lbpkit::servoCycle(t, ss, &enc).ok);
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
    if (lbpkit::servoCycle(t, ss, &enc).replyLost) ++lost;
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
    (void)lbpkit::servoCycle(t, ss, &enc);
    t.sleep(1ms);
  }
  EXPECT_EQ(tAllocations - before, 0U);
  EXPECT_GE(t.linkCounters().lostReplies, 6U);
  EXPECT_GE(t.linkCounters().discarded, 1U);
  ss.stopAll();
}

// The machine is stepped on the card thread, a trace row taken at every
// host cycle (lbpkit sim --machine): neither allocates, axes moving,
// encoders counting, the spindle turning, a push under way.
TEST(RealTime, TheMachineAndItsTraceDoNotAllocate) {
  testing_host::RunningCard rc;
  auto& t = rc.t;
  auto& ss = rc.ss;
  machine::Machine m(machine::mill(), t.card(), hm2::SimTime{t.now()});
  server::TraceRing ring(m.traceColumns(), 100);
  std::vector<double> row(ring.width());
  ss.setRaw(ss.find(1, "analogena"), 1);
  ss.setRaw(ss.find(1, "spinena"), 1);
  ss.setRaw(ss.find(0, "output"), 1U << 2);  // Z's brake released
  const auto a0 = ss.find(1, "analogout0");
  ss.set(ss.find(1, "analogout5"), 3.0);
  m.push(1, 50.0, 20.0);  // 2.5 s
  auto cycle = [&](int i) {
    ss.set(a0, (i % 400) < 200 ? 2.0 : -2.0);
    ASSERT_TRUE(ss.cycle().ok);
    m.advance(hm2::SimTime{t.now() + 1ms});
    m.traceRow(row);
    ring.push(row);
    t.sleep(1ms);
  };
  for (int i = 0; i < 10; ++i) cycle(i);  // warm up
  const auto before = gAllocations.load();
  for (int i = 0; i < 1000; ++i) cycle(i);
  EXPECT_EQ(gAllocations.load() - before, 0U);
  EXPECT_TRUE(m.axis(1).pushing());
  EXPECT_GT(m.state().spindle->rpm, 1000.0);
  EXPECT_NE(m.axis(0).position(), 200.0);
}

TEST(RealTime, TheLbp16DatagramPathDoesNotAllocate) {
  hm2::HostMot2Card card;
  server::Lbp16Card lbp16(card, {});
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
  std::uint8_t reply[server::Lbp16Card::kMaxDatagram];
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
