// SPDX-License-Identifier: MIT
// An SSLBP channel brought out to a remote of the user's
// own. First SSLBP's external path with the remote's bytes fed by hand, then
// the same through a pseudo-terminal (PtyChannel), the test answering as
// the remote with an in-process 7I77 field I/O processor.
#include <fcntl.h>
#include <poll.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <thread>
#include <vector>

#include "support/card_host.hpp"
#include "lbp/protocol.hpp"
#include "support/process.hpp"
#include "support/sim_child.hpp"
#include "support/temp_dir.hpp"
#include "pty/pty_channel.hpp"
#include "remote/field_io.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace remote = lbpkit::model::remote;
namespace lbp = lbpkit::model::lbp;
namespace server = lbpkit::server;

namespace {

using namespace std::chrono_literals;

using namespace testing_hm2;
namespace cmd = hm2::command;
namespace cs = hm2::cs;
using hm2::Sslbp;

constexpr unsigned kExpansion = 2;  // TB6: nothing on it in the default card

// Runs `command` with `serve` called before every register access (the
// remote's side of the line); returns DATA, and in `took` how long it ran.
std::uint8_t commandServed(CardHost& h, std::uint32_t command, const std::function<void()>& serve, SimTime& took,
                           SimTime step = SimTime{1000}) {
  h.write(Sslbp::kCommand, command);
  const SimTime start = h.now;
  for (;;) {
    serve();
    if (h.read(Sslbp::kCommand) == 0) break;
    if (h.now - start > 10s) {
      ADD_FAILURE() << "command " << std::hex << command << " never completed";
      break;
    }
    h.wait(step);
  }
  took = h.now - start;
  return static_cast<std::uint8_t>(h.read(Sslbp::kData));
}

// The remote's side fed by hand: the outbox to the processor, its replies
// back to SSLBP at the same simulated time.
struct HandFed {
  hm2::HostMot2Card& card;
  remote::FieldIoProcessor& io;
  CardHost& h;
  bool answering = true;
  void operator()() {
    auto& link = card.part<hm2::Sslbp>().link(kExpansion);
    std::vector<std::uint8_t> reply;
    for (std::uint8_t b : link.outbox())
      for (std::uint8_t r : io.receive(b, h.now)) reply.push_back(r);
    link.consumeOutbox(link.outbox().size());
    if (answering && !reply.empty()) card.part<hm2::Sslbp>().remoteBytes(kExpansion, reply, h.now);
  }
};

// Channel 2 external, all channels stopped, remote mode 0 in its CS.
class SslbpExternal : public ::testing::Test {
 protected:
  void SetUp() override {
    card.part<hm2::Sslbp>().link(kExpansion).setExternal(true);
    h.command(cmd::kStop);
    h.write(CardHost::cs(kExpansion), 0);
  }
  hm2::HostMot2Card card;
  CardHost h{card};
  remote::FieldIoProcessor io;
  HandFed serve{card, io, h};
  SimTime took{};
};

TEST_F(SslbpExternal, SetupStartAndRemoteCommandsWithBytesFedByHand) {
  EXPECT_EQ(commandServed(h, cmd::kSetupStart | (1U << kExpansion), std::ref(serve), took), 0);
  EXPECT_EQ(h.read(CardHost::cs(kExpansion)), 0x00400000U);  // setup run (COM_STATE 0x40), no errors
  EXPECT_EQ(h.read(CardHost::iface(0, kExpansion)), io.unitNumber());  // discovery's unit number
  // A setup-mode word read through CS and DOIT: the watchdog time, 50 ms.
  const auto wd = io.address(io.standard(remote::Standard::WatchdogTime));
  h.write(CardHost::cs(kExpansion), (0x45U << 24) | wd);
  EXPECT_EQ(commandServed(h, cmd::kDoit | (1U << kExpansion), std::ref(serve), took), 0);
  EXPECT_EQ(h.read(CardHost::iface(0, kExpansion)) & 0xFFFF, 50U);
  EXPECT_EQ(h.read(CardHost::cs(kExpansion)) & 0xFFU, 0U);
}

TEST_F(SslbpExternal, RelaxedTimeoutAndLateAndDamagedReplies) {
  // Nobody answering: SETUP START gives up after its 21 cookie requests, each
  // waiting kExternalTimeoutFactor times the 6-tick (1.2 ms) setup timeout,
  // where the cable's channel takes 54.62 ms in all (Sslbp.NoRemoteSetupStartMatchesFirmware43).
  serve.answering = false;
  EXPECT_EQ(commandServed(h, cmd::kSetupStart | (1U << kExpansion), std::ref(serve), took, SimTime{100'000}),
            1U << kExpansion);
  const SimTime oneWait = SimTime{1'200'000} * Sslbp::kExternalTimeoutFactor;
  EXPECT_GT(took, oneWait * 21);
  EXPECT_LT(took, oneWait * 22);
  EXPECT_NE(h.read(CardHost::cs(kExpansion)) & cs::kTooManyErrors, 0U);

  // Answering in time after a STOP: started.
  h.command(cmd::kStop | (1U << kExpansion));
  serve.answering = true;
  ASSERT_EQ(commandServed(h, cmd::kSetupStart | (1U << kExpansion), std::ref(serve), took), 0);
  EXPECT_EQ(h.read(CardHost::cs(kExpansion)) & 0xFFU, 0U);

  // A reply with a damaged character: a CRC error, and the read times out.
  const auto wd = io.address(io.standard(remote::Standard::WatchdogTime));
  h.write(CardHost::cs(kExpansion), (0x45U << 24) | wd);
  h.write(Sslbp::kCommand, cmd::kDoit | (1U << kExpansion));
  h.wait(SimTime{10'000});
  auto& link = card.part<hm2::Sslbp>().link(kExpansion);
  std::vector<std::uint8_t> reply;
  for (std::uint8_t b : link.outbox())
    for (std::uint8_t r : io.receive(b, h.now)) reply.push_back(r);
  link.consumeOutbox(link.outbox().size());
  ASSERT_EQ(reply.size(), 3U);  // two data bytes and the CRC
  const auto good = reply;
  reply[0] ^= 0x5A;
  card.part<hm2::Sslbp>().remoteBytes(kExpansion, reply, h.now);
  EXPECT_NE(h.read(CardHost::cs(kExpansion)) & cs::kCrcError, 0U);
  // Discarded: the channel waits out setup mode's 50 ms timeout, relaxed.
  h.wait(SimTime{50ms} * Sslbp::kExternalTimeoutFactor - SimTime{1ms});
  EXPECT_NE(h.read(Sslbp::kCommand), 0U);
  h.wait(SimTime{2ms});
  EXPECT_EQ(h.read(Sslbp::kCommand), 0U);
  // Since SSLBP 40 a setup-mode timeout shows in CS, not in DATA.
  EXPECT_EQ(h.read(Sslbp::kData), 0U);
  EXPECT_NE(h.read(CardHost::cs(kExpansion)) & cs::kTimeout, 0U);
  // The good reply after the timeout: too late, it lands in the receive
  // FIFO; the next transmit finds it there (an extra character).
  card.part<hm2::Sslbp>().remoteBytes(kExpansion, good, h.now);
  EXPECT_EQ(h.read(CardHost::cs(kExpansion)) & cs::kExtraCharacter, 0U);
  EXPECT_EQ(commandServed(h, cmd::kDoit | (1U << kExpansion), std::ref(serve), took), 0);
  EXPECT_EQ(h.read(CardHost::iface(0, kExpansion)) & 0xFFFF, 50U);
  EXPECT_NE(h.read(CardHost::cs(kExpansion)) & cs::kExtraCharacter, 0U);
}

// The remote's side through the pty's slave, as a user's program would. A
// pty delivers what is written after a kernel work item: simulated time
// stands still until everything the channel sent has reached the remote and
// the remote's replies have reached the channel, so the test does not depend
// on how fast the machine is.
struct PtyServed {
  hm2::HostMot2Card& card;
  server::PtyChannel& channel;
  remote::FieldIoProcessor& io;
  CardHost& h;
  int fd;
  std::uint64_t heard = 0;     // bytes the remote has read
  std::uint64_t answered = 0;  // bytes it has written
  void operator()() {
    using Clock = std::chrono::steady_clock;
    const auto giveUp = Clock::now() + 5s;
    channel.pump(card, h.now);
    while (heard < channel.bytesToRemote() && Clock::now() < giveUp) {
      pollfd p{fd, POLLIN, 0};
      ::poll(&p, 1, 100);
      std::uint8_t buffer[256];
      const ssize_t n = ::read(fd, buffer, sizeof buffer);
      for (ssize_t i = 0; i < n; ++i) {
        const auto reply = io.receive(buffer[i], h.now);
        if (reply.empty()) continue;
        ASSERT_EQ(::write(fd, reply.data(), reply.size()), static_cast<ssize_t>(reply.size()));
        answered += reply.size();
      }
      if (n > 0) heard += static_cast<std::uint64_t>(n);
    }
    while (channel.bytesFromRemote() < answered && Clock::now() < giveUp) {
      std::this_thread::yield();
      channel.pump(card, h.now);
    }
  }
};

TEST(PtyChannel, RemoteOnThePtyAnswersSetupStartAndCommands) {
  hm2::HostMot2Card card;
  CardHost h{card};
  server::PtyChannel channel(card, kExpansion);
  EXPECT_TRUE(card.part<hm2::Sslbp>().link(kExpansion).external());
  const int fd = ::open(channel.path().c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  ASSERT_GE(fd, 0) << channel.path();
  remote::FieldIoProcessor io;
  PtyServed served{card, channel, io, h, fd};
  h.command(cmd::kStop);
  h.write(CardHost::cs(kExpansion), 0);
  SimTime took{};
  EXPECT_EQ(commandServed(h, cmd::kSetupStart | (1U << kExpansion), std::ref(served), took), 0);
  EXPECT_EQ(h.read(CardHost::iface(0, kExpansion)), io.unitNumber());
  EXPECT_GT(channel.bytesToRemote(), 0U);
  EXPECT_GT(channel.bytesFromRemote(), 0U);
  // Setup-mode commands through CS and DOIT, served over the pty: the card
  // name's first byte (local read 0xD0) and the watchdog time.
  auto remoteCommand = [&](std::uint8_t header, std::uint16_t address) {
    h.write(CardHost::cs(kExpansion), (static_cast<std::uint32_t>(header) << 24) | address);
    SimTime t{};
    EXPECT_EQ(commandServed(h, cmd::kDoit | (1U << kExpansion), std::ref(served), t), 0);
    return h.read(CardHost::iface(0, kExpansion));
  };
  EXPECT_EQ(remoteCommand(lbp::local_read::kCardName0, 0) & 0xFF, static_cast<std::uint32_t>('7'));
  const auto wd = io.address(io.standard(remote::Standard::WatchdogTime));
  EXPECT_EQ(remoteCommand(0x45, wd) & 0xFFFF, 50U);
  EXPECT_EQ(h.read(CardHost::cs(kExpansion)) & 0xFFU, 0U);  // no errors
  ::close(fd);
}

TEST(PtyChannel, NobodyOnThePtyStartFailsAfterTheRelaxedTimeout) {
  hm2::HostMot2Card card;
  CardHost h{card};
  server::PtyChannel channel(card, kExpansion);
  h.command(cmd::kStop);
  h.write(CardHost::cs(kExpansion), 0);
  SimTime took{};
  EXPECT_EQ(commandServed(h, cmd::kStart | (1U << kExpansion), [&] { channel.pump(card, h.now); }, took,
                          SimTime{100'000}),
            1U << kExpansion);
  // Normal START: 21 cookie requests, each waiting 200 ticks (400 us) times the factor.
  EXPECT_GT(took, SimTime{400'000} * Sslbp::kExternalTimeoutFactor * 21);
  EXPECT_NE(h.read(CardHost::cs(kExpansion)) & cs::kTimeout, 0U);
  EXPECT_GT(channel.bytesToRemote(), 0U);  // the requests went out on the pty
}

TEST(PtyChannel, RefusesAChannelWithA7I77ProcessorOrNone) {
  hm2::HostMot2Card card;
  try {
    server::PtyChannel channel(card, 0);
    ADD_FAILURE() << "channel 0 taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "channel 0 carries the 7I77's field I/O processor");
  }
  try {
    server::PtyChannel channel(card, 1);
    ADD_FAILURE() << "channel 1 taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "channel 1 carries the 7I77's analog processor");
  }
  EXPECT_THROW(server::PtyChannel(card, 6), std::invalid_argument);
  EXPECT_FALSE(card.part<hm2::Sslbp>().link(0).external());
}

// `lbpkit sim --remote`: a 7I77's channel, or a bad value, is refused before anything starts.
TEST(PtyChannel, SimRefusesAChannelWithA7I77Processor) {
  using test_support::run;
  const auto state = std::filesystem::temp_directory_path() / ("lbpkit-ptych0-" + std::to_string(::getpid()));
  auto r = run({"sim", "--bind", "127.0.0.1:0", "--api", "0", "--state", state.string(), "--remote", "0=pty"},
               std::chrono::seconds(10));
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find("--remote 0=pty: channel 0 carries the 7I77's field I/O processor"), std::string::npos) << r.err;
  r = run({"sim", "--bind", "127.0.0.1:0", "--api", "0", "--remote", "2=serial"}, std::chrono::seconds(10));
  EXPECT_EQ(r.exit, 1);
  EXPECT_NE(r.err.find("--remote \"2=serial\": give CHANNEL=pty"), std::string::npos) << r.err;
  test_support::removeStateFiles(state.string());
}

// The whole path: `lbpkit sim --remote 2=pty`, a remote of our own on the
// pty printed in the banner, and `lbpkit discover` over LBP16 finding it.
TEST(PtyChannel, SimChannelOnAPtyIsDiscovered) {
  const auto state = std::filesystem::temp_directory_path() / ("lbpkit-ptych-" + std::to_string(::getpid()));
  test_support::Daemon sim({"sim", "--bind", "127.0.0.1:0", "--api", "0", "--no-realtime", "--state",
                            state.string(), "--remote", "2=pty", "--ready-fd", "3"},
                           true);
  const auto card = test_support::greeting(sim)["cards"][0];
  ASSERT_TRUE(card.is_object());
  const std::string port = std::to_string(card["lbp16"]["port"].get<int>());
  ASSERT_EQ(card["external_remotes"].size(), 1U) << card.dump();
  EXPECT_EQ(card["external_remotes"][0]["channel"], 2);
  const std::string path = card["external_remotes"][0]["pty"].get<std::string>();
  ASSERT_FALSE(port.empty());
  ASSERT_EQ(path.rfind("/dev/pts/", 0), 0U) << path;
  // The banner tells a person the same, with the link's speed.
  const std::string line = sim.value("channel 2: external remote on ");
  EXPECT_EQ(line.substr(0, line.find(' ')), path) << line;
  EXPECT_NE(line.find("(LBP at 2500000 baud; reply timeouts x100)"), std::string::npos) << line;
  const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  ASSERT_GE(fd, 0) << path;
  std::atomic<bool> stop{false};
  std::thread remoteSide([&] {
    remote::FieldIoProcessor io;
    const auto start = std::chrono::steady_clock::now();
    while (!stop.load()) {
      pollfd p{fd, POLLIN, 0};
      if (::poll(&p, 1, 10) <= 0) continue;
      std::uint8_t buffer[256];
      const ssize_t n = ::read(fd, buffer, sizeof buffer);
      const SimTime now = std::chrono::duration_cast<SimTime>(std::chrono::steady_clock::now() - start);
      for (ssize_t i = 0; i < n; ++i) {
        const auto reply = io.receive(buffer[i], now);
        if (!reply.empty() && ::write(fd, reply.data(), reply.size()) < 0) return;
      }
    }
  });
  const auto r = test_support::run({"discover", "--addr", "127.0.0.1:" + port, "--modes", "xx0"},
                                      std::chrono::seconds(30));
  stop = true;
  remoteSide.join();
  ::close(fd);
  EXPECT_EQ(r.exit, 0) << r.err;
  EXPECT_NE(r.out.find("channel 2: 7I77 field I/O unit 0x12000AEE"), std::string::npos) << r.out << r.err;
  EXPECT_NE(r.out.find("WatchDogTime"), std::string::npos) << r.out;
  EXPECT_EQ(sim.stopWithin(std::chrono::seconds(10)), 0);
  test_support::removeStateFiles(state.string());
}

}  // namespace
