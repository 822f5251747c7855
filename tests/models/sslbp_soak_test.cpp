// SPDX-License-Identifier: MIT
// A randomized soak of what hosts do to SSLBP: STOP (all and single), START
// (normal and setup), DOIT, local reads, setup-mode LBP commands and
// remote resets, commands written while busy or with the ignore bit, pauses
// long enough for watchdogs to bite, and the faults the control API injects
// (cut cables, corrupted, dropped and extra characters, breaks, field power
// sags, shorted outputs). After every burst the faults are cleared and the
// invariant is checked: a STOP ALL and a START bring both 7I77 channels back
// (DATA 0, no communication error) and a DOIT then succeeds on both.
//
// The burst is short in ctest. For the long soak (docs/reliability.md):
//   LBPKIT_SOAK_STEPS=2000000 LBPKIT_SOAK_SEED=7
//   build/default/tests/lbpkit_tests --gtest_filter='SslbpSoak.*'
// (both on one line).
#include <gtest/gtest.h>

#include <cstdlib>
#include <deque>
#include <random>
#include <sstream>
#include <string>

#include "support/card_host.hpp"
#include "lbp/protocol.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace lbp = lbpkit::model::lbp;

namespace {

using namespace testing_hm2;
namespace cmd = hm2::command;
using hm2::SerialLink;
using hm2::Sslbp;

std::uint64_t envOr(const char* name, std::uint64_t fallback) {
  const char* v = std::getenv(name);
  return v ? std::strtoull(v, nullptr, 0) : fallback;
}

class Soak {
 public:
  explicit Soak(std::uint64_t seed) : rng_(seed), h_{card_} {}

  // One random host action or fault.
  void step() {
    const unsigned op = pick(100);
    if (op < 20) doit();
    else if (op < 28) start(false);
    else if (op < 33) start(true);
    else if (op < 38) note("STOP ALL"), write(cmd::kStop), waitSome();
    else if (op < 42) stopOne();
    else if (op < 50) localRead();
    else if (op < 60) setupCommand();
    else if (op < 64) note("command while busy"), write(cmd::kDoit | 0x03), write(cmd::kStart | 0x03);
    else if (op < 66) note("ignored command"), write(cmd::kIgnore | cmd::kStop);
    else if (op < 72) pause();
    else if (op < 80) linkFault();
    else if (op < 84) cable();
    else if (op < 88) fieldPower();
    else if (op < 91) shortOutput();
    else if (op < 93) resetBit();
    else waitSome();
  }

  // Clear every fault, then STOP ALL and START: both channels must come back.
  void checkRecovers(std::uint64_t at) {
    for (unsigned ch = 0; ch < 2; ++ch) card_.part<hm2::Sslbp>().link(ch).setConnected(true);
    auto& io = card_.daughtercard(0).fieldIo;
    io.setFieldVoltage(24.0, h_.now);
    for (unsigned o = 0; o < 16; ++o) io.setOutputLoad(o, 1e6);
    if (h_.read(Sslbp::kCommand) & cmd::kReset) write(0);  // release the reset bit
    // Let whatever runs finish (a START on a dead line takes tens of ms).
    ASSERT_GE(h_.waitCommand(std::chrono::seconds(2)).count(), 0) << "COMMAND never cleared" << history();
    h_.write(Sslbp::kCommand, cmd::kStop);
    ASSERT_GE(h_.waitCommand(std::chrono::seconds(2)).count(), 0) << "STOP ALL never completed" << history();
    h_.write(CardHost::cs(0), 0);
    h_.write(CardHost::cs(1), 0);
    h_.write(Sslbp::kCommand, cmd::kStart | 0x03);
    ASSERT_GE(h_.waitCommand(std::chrono::seconds(2)).count(), 0) << "START never completed" << history();
    const auto data = h_.read(Sslbp::kData);
    ASSERT_EQ(data, 0U) << "after step " << at << " STOP ALL + START left channels 0x" << std::hex << data
                        << " failed; CS0 0x" << h_.read(CardHost::cs(0)) << " CS1 0x" << h_.read(CardHost::cs(1))
                        << " lost commands " << std::dec << card_.part<hm2::Sslbp>().counters().lostCommands << history();
    h_.write(Sslbp::kCommand, cmd::kDoit | 0x03);
    ASSERT_GE(h_.waitCommand().count(), 0) << history();
    ASSERT_EQ(h_.read(Sslbp::kData), 0U) << "the first DOIT after START failed" << history();
    history_.clear();
  }

 private:
  unsigned pick(unsigned n) { return static_cast<unsigned>(rng_() % n); }
  void note(std::string s) {
    history_.push_back(std::move(s));
    if (history_.size() > 40) history_.pop_front();
  }
  std::string history() const {
    std::ostringstream o;
    o << "\nlast actions:";
    for (const auto& s : history_) o << "\n  " << s;
    return o.str();
  }
  void write(std::uint32_t v) { h_.write(Sslbp::kCommand, v); }
  // Most of the time the host waits for a command; sometimes it does not.
  void waitSome() {
    if (pick(4) == 0) return;
    h_.waitCommand(std::chrono::milliseconds(pick(3) == 0 ? 50 : 5));
  }
  void doit() {
    note("DOIT");
    h_.write(CardHost::iface(0, 0), static_cast<std::uint32_t>(rng_()));
    h_.write(CardHost::iface(0, 1), static_cast<std::uint32_t>(rng_()));
    write(cmd::kDoit | (1U + pick(3)));
    waitSome();
  }
  void start(bool setup) {
    const unsigned mask = 1U + pick(7);  // channel 2 has nothing attached
    note(std::string(setup ? "setup START 0x" : "START 0x") + std::to_string(mask));
    h_.write(CardHost::cs(0), pick(5) << 24);  // modes 0..3, and 4, which the field I/O does not have
    h_.write(CardHost::cs(1), 0);
    write((setup ? cmd::kSetupStart : cmd::kStart) | mask);
    waitSome();
  }
  void stopOne() {
    const unsigned ch = pick(3);
    note("STOP channel " + std::to_string(ch));
    write(cmd::kStop | (1U << ch));
    waitSome();
  }
  void localRead() {
    note("local read");
    write(cmd::kRequest | pick(0x200));
    waitSome();
  }
  void setupCommand() {
    const unsigned ch = pick(2);
    static constexpr std::uint8_t kHeaders[] = {
        lbp::readHeader(1, true), lbp::readHeader(2, true), lbp::readHeader(4, true), lbp::readHeader(8, true),
        lbp::local_read::kStatus, lbp::local_read::kCookie, lbp::local_read::kUnitId};
    std::uint8_t header = kHeaders[pick(std::size(kHeaders))];
    std::uint16_t address = static_cast<std::uint16_t>(pick(0x1000));
    std::uint64_t data = 0;
    if (pick(8) == 0) {  // reset the remote processor (local write 0xFE, key 0x5A)
      header = lbp::local_write::kResetProcessor;
      address = 0;
      data = lbp::kResetKey;
    }
    note("setup LBP 0x" + std::to_string(header) + " on channel " + std::to_string(ch));
    h_.write(CardHost::iface(0, ch), static_cast<std::uint32_t>(data));
    h_.write(CardHost::cs(ch), (static_cast<std::uint32_t>(header) << 24) | address);
    write(cmd::kDoit | (1U << ch));
    waitSome();
  }
  void pause() {
    const auto ms = pick(3) == 0 ? 200 : pick(60);
    note("pause " + std::to_string(ms) + " ms");
    h_.wait(std::chrono::milliseconds(ms));
  }
  void linkFault() {
    auto& link = card_.part<hm2::Sslbp>().link(pick(2));
    const auto dir = pick(2) ? SerialLink::Direction::FromRemote : SerialLink::Direction::ToRemote;
    switch (pick(4)) {
      case 0: note("corrupt"), link.corruptNext(dir, 1 + pick(3)); break;
      case 1: note("drop"), link.dropNext(dir, 1 + pick(3)); break;
      case 2: note("extra"), link.addExtra(dir, 1 + pick(2)); break;
      default: note("break"), link.breakNext(); break;
    }
  }
  void cable() {
    const unsigned ch = pick(2);
    const bool on = pick(2) != 0;
    note(std::string(on ? "plug" : "unplug") + " channel " + std::to_string(ch));
    card_.part<hm2::Sslbp>().link(ch).setConnected(on);
  }
  void fieldPower() {
    const double v = pick(2) ? 24.0 : 3.0 + pick(15);
    note("field " + std::to_string(v) + " V");
    card_.daughtercard(0).fieldIo.setFieldVoltage(v, h_.now);
  }
  void shortOutput() {
    const unsigned o = pick(16);
    note("short output " + std::to_string(o));
    card_.daughtercard(0).fieldIo.setOutputLoad(o, pick(2) ? 0.1 : 1e6);
  }
  void resetBit() {
    note("reset bit");
    write(cmd::kReset);
    h_.wait(std::chrono::microseconds(pick(500)));
    write(pick(2) ? 0x0001 : 0);
    waitSome();
  }

  std::mt19937_64 rng_;
  hm2::HostMot2Card card_;
  CardHost h_;
  std::deque<std::string> history_;
};

TEST(SslbpSoak, StopAllAndStartAlwaysBringBothChannelsBack) {
  const std::uint64_t steps = envOr("LBPKIT_SOAK_STEPS", 4000);
  const std::uint64_t seed = envOr("LBPKIT_SOAK_SEED", 1);
  Soak soak(seed);
  for (std::uint64_t i = 1; i <= steps; ++i) {
    soak.step();
    if (i % 50 == 0) {
      soak.checkRecovers(i);
      if (testing::Test::HasFatalFailure()) {
        ADD_FAILURE() << "seed " << seed;
        return;
      }
    }
  }
  soak.checkRecovers(steps);
}

}  // namespace
