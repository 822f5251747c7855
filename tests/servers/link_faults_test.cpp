// SPDX-License-Identifier: MIT
// A noisy RS-422 cable on purpose: the link's faults at a
// rate, what each end of the link makes of them (the SSLBP channel's CS bits
// and judged errors, the remote's own CRC error count: manual, CS REGISTER
// AFTER START and LBP LOCAL READ 0xC3), and the ways to ask for them: the
// control API (POST/GET /api/link), `lbpkit fault link` and a fault script.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "config/fault_script.hpp"
#include "daemon/fault_script.hpp"
#include "daemon/link_api.hpp"
#include "daemon/sim_clock.hpp"
#include "hostmot2/serial_link.hpp"
#include "lbpkit/lbp16_transport.hpp"
#include "lbpkit/sserial.hpp"
#include "lbpkit/wire/sslbp.hpp"
#include "support/process.hpp"
#include "support/sim_child.hpp"
#include "support/running_card.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace lbp = lbpkit::model::lbp;
namespace server = lbpkit::server;
namespace config = lbpkit::config;

namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using hm2::SerialLink;
namespace cs = lbpkit::wire::sslbp::cs;

// Sends `frames` frames of `size` characters to a remote that is not there
// (so nothing comes back) and returns the link's counters.
SerialLink::Counters sendFrames(SerialLink& link, unsigned frames, unsigned size) {
  std::vector<std::uint8_t> frame(size, 0x00);
  hm2::SimTime t{0};
  for (unsigned i = 0; i < frames; ++i) {
    const auto r = link.exchange(frame, t, 2'500'000);
    t = r.lastByteAt + 1ms;
  }
  return link.counters();
}

TEST(SerialLinkRates, BitErrorsComeAtTheirRateAndRepeatWithTheSeed) {
  SerialLink::RateSettings s;
  s.toRemote.bitErrorRate = 1e-2;
  s.seed = 42;
  SerialLink a, b;
  a.setRates(s);
  b.setRates(s);
  const auto ca = sendFrames(a, 1000, 100);  // 800 000 data bits
  const auto cb = sendFrames(b, 1000, 100);
  EXPECT_NEAR(static_cast<double>(ca.bitErrors), 8000, 8000 * 0.05);
  EXPECT_EQ(ca.bitErrors, cb.bitErrors) << "the same seed, the same errors";
  EXPECT_EQ(ca.corrupted, cb.corrupted);
  // A character with one flipped bit or more is one corrupted character.
  EXPECT_LE(ca.corrupted, ca.bitErrors);
  EXPECT_GT(ca.corrupted, ca.bitErrors * 9 / 10);
  EXPECT_EQ(ca.toRemote, 100'000U);
  EXPECT_EQ(ca.dropped, 0U);
  s.seed = 43;
  SerialLink c;
  c.setRates(s);
  EXPECT_NE(sendFrames(c, 1000, 100).bitErrors, ca.bitErrors) << "another seed, other errors";
}

TEST(SerialLinkRates, DropsAndExtrasComeAtTheirRatesInTheirDirectionOnly) {
  SerialLink::RateSettings s;
  s.toRemote.dropRate = 0.1;
  s.toRemote.extraRate = 0.05;
  SerialLink link;
  link.setRates(s);
  const auto c = sendFrames(link, 1000, 10);
  EXPECT_NEAR(static_cast<double>(c.dropped), 1000, 150);
  EXPECT_NEAR(static_cast<double>(c.added), 500, 110);
  EXPECT_EQ(c.bitErrors, 0U);
  EXPECT_EQ(c.breaks, 0U);
  SerialLink quiet;
  SerialLink::RateSettings back;
  back.fromRemote.dropRate = 1;  // nothing comes back from a remote that is not there
  quiet.setRates(back);
  EXPECT_EQ(sendFrames(quiet, 100, 10).dropped, 0U);
}

// The field I/O processor on channel 0 of the in-process card, started in
// normal mode, at 1 kHz.
struct Running {
  testing_host::RunningCard rc;
  hm2::Sslbp& sserial = rc.t.card().part<hm2::Sslbp>();
  // Cycles; returns how many failed on `channel`.
  unsigned cycles(unsigned n, unsigned channel = 0) {
    unsigned failed = 0;
    for (unsigned i = 0; i < n; ++i) {
      const auto st = rc.ss.cycle();
      if (st.failedMask & (1U << channel)) ++failed;
      rc.t.sleep(1ms);
    }
    return failed;
  }
  hm2::Sslbp::State::Channel channel(unsigned ch) { return sserial.state().channel[ch]; }
  unsigned remoteCrcErrors(unsigned ch) { return sserial.link(ch).remote()->crcErrorCount(); }
};

TEST(LinkFaults, ErrorsTowardTheRemoteAreCountedByItsCrcAndTimeOutAtTheCard) {
  Running r;
  ASSERT_EQ(r.cycles(20), 0U);
  SerialLink::RateSettings s;
  s.toRemote.bitErrorRate = 0.02;  // about one command in eight damaged
  r.sserial.link(0).setRates(s);
  const unsigned failed = r.cycles(100);
  const auto c = r.channel(0);
  EXPECT_GT(c.link.corrupted, 0U);
  EXPECT_GT(failed, 0U);
  // The remote found the damaged commands by their CRC and did not answer
  // (manual, LBP: a command with a bad CRC is ignored); the card timed out.
  EXPECT_GT(r.remoteCrcErrors(0), 0U);
  EXPECT_LE(r.remoteCrcErrors(0), c.link.corrupted);
  EXPECT_GT(c.errors.timeout, 0U);
  EXPECT_EQ(c.errors.crc, 0U) << "nothing damaged on the way back";
  EXPECT_TRUE((c.cs & cs::kTimeout) != 0) << std::hex << c.cs;
  EXPECT_EQ(r.remoteCrcErrors(1), 0U) << "the analog processor's cable is clean";
}

TEST(LinkFaults, ErrorsFromTheRemoteAreCrcErrorsAtTheCard) {
  Running r;
  ASSERT_EQ(r.cycles(20), 0U);
  SerialLink::RateSettings s;
  s.fromRemote.bitErrorRate = 0.02;
  r.sserial.link(0).setRates(s);
  EXPECT_GT(r.cycles(100), 0U);
  const auto c = r.channel(0);
  EXPECT_GT(c.errors.crc, 0U);
  EXPECT_TRUE((c.cs & cs::kCrcError) != 0) << std::hex << c.cs;
  EXPECT_EQ(r.remoteCrcErrors(0), 0U) << "the commands arrived whole";
}

TEST(LinkFaults, BreaksExtrasAndACutEachShowTheirOwnBit) {
  Running r;
  ASSERT_EQ(r.cycles(20), 0U);
  SerialLink::RateSettings s;
  s.breakRate = 0.2;
  r.sserial.link(0).setRates(s);
  EXPECT_GT(r.cycles(50), 0U);
  EXPECT_GT(r.channel(0).errors.serialBreak, 0U);
  EXPECT_TRUE((r.channel(0).cs & cs::kSerialBreak) != 0);

  Running e;
  ASSERT_EQ(e.cycles(20), 0U);
  SerialLink::RateSettings x;
  x.fromRemote.extraRate = 0.05;
  e.sserial.link(0).setRates(x);
  e.cycles(100);
  EXPECT_GT(e.channel(0).errors.extraCharacter, 0U);
  EXPECT_TRUE((e.channel(0).cs & cs::kExtraCharacter) != 0);

  // The cable out for 10 ms, then back: every DOIT in between fails, and
  // after it (and the host's recovery, once the card gave up) the channel
  // works again.
  Running c;
  ASSERT_EQ(c.cycles(20), 0U);
  const auto now = c.rc.t.card().now();
  c.sserial.link(0).cut(now, now + 10ms);
  EXPECT_GE(c.cycles(10), 9U);
  for (unsigned slot = 0; slot < c.rc.ss.slots(); ++slot) c.rc.ss.recover(slot);
  EXPECT_EQ(c.cycles(20), 0U);
  EXPECT_GT(c.channel(0).errors.timeout, 0U);
}

// --- The control API, the CLI and a fault script.

class SimLink : public ::testing::Test {
 protected:
  void SetUp() override {
    sim_ = std::make_unique<test_support::SimChild>(test_support::SimOptions{address_, 0, "127.0.0.1", true, {}, {}});
    api_ = sim_->apiPort();
    port_ = sim_->udpPort();
    ASSERT_GT(api_, 0);
    ASSERT_GT(port_, 0);
  }
  void TearDown() override { sim_.reset(); }
  std::pair<int, json> post(const json& body) {
    auto r = sim_->post("/api/link", body);
    return {r.status, r.body};
  }
  json get() { return sim_->get("/api/link"); }
  const std::string address_ = "127.95." + std::to_string(::getpid() % 250) + ".1";
  std::unique_ptr<test_support::SimChild> sim_;
  int api_ = 0, port_ = 0;
};

TEST_F(SimLink, TheApiSetsALinkAndShowsWhatBothEndsCounted) {
  // Mistakes: 400, naming the key, and nothing changes.
  auto bad = post({{"bit_error_rate", 0.1}});
  EXPECT_EQ(bad.first, 400);
  EXPECT_NE(bad.second.value("error", "").find("\"channel\""), std::string::npos) << bad.second.dump();
  bad = post({{"channel", 0}, {"bit_error_rate", 1.5}});
  EXPECT_EQ(bad.first, 400);
  EXPECT_NE(bad.second.value("error", "").find("\"bit_error_rate\""), std::string::npos) << bad.second.dump();
  bad = post({{"channel", 0}, {"direction", "sideways"}, {"drop_rate", 0.1}});
  EXPECT_NE(bad.second.value("error", "").find("\"direction\""), std::string::npos) << bad.second.dump();
  bad = post({{"channel", 0}, {"bit_error_rte", 0.1}});
  EXPECT_NE(bad.second.value("error", "").find("bit_error_rte"), std::string::npos) << bad.second.dump();
  bad = post({{"channel", 99}, {"bit_error_rate", 0.1}});
  EXPECT_EQ(bad.first, 400);
  EXPECT_EQ(get()["channels"][0]["set"]["to_remote"]["bit_error_rate"], 0.0);

  // Errors from the field I/O processor only, while a host of ours runs it.
  const auto set = post({{"channel", 0}, {"direction", "from_remote"}, {"bit_error_rate", 0.02}, {"seed", 7}});
  ASSERT_EQ(set.first, 200) << set.second.dump();
  EXPECT_EQ(set.second["channels"][0]["set"]["from_remote"]["bit_error_rate"], 0.02);
  EXPECT_EQ(set.second["channels"][0]["set"]["to_remote"]["bit_error_rate"], 0.0);
  EXPECT_EQ(set.second["channels"][0]["set"]["seed"], 7);
  {
    lbpkit::Lbp16Transport t(address_, static_cast<std::uint16_t>(port_));
    const auto info = lbpkit::readCardInfo(t);
    lbpkit::SmartSerial ss(t, info, testing_host::channels(0x03));
    post({{"channel", 0}, {"clear", true}});  // discovery on a good cable
    ss.discover(0x03);
    ss.startNormal();
    post({{"channel", 0}, {"direction", "from_remote"}, {"bit_error_rate", 0.02}, {"seed", 7}});
    unsigned failed = 0;
    for (int i = 0; i < 200; ++i) failed += (ss.cycle().failedMask & 1U) != 0 ? 1U : 0U;
    EXPECT_GT(failed, 0U);
  }
  const auto j = get()["channels"][0];
  EXPECT_GT(j["did"]["bits_flipped"].get<std::uint64_t>(), 0U) << j.dump();
  EXPECT_GT(j["did"]["characters_from_remote"].get<std::uint64_t>(), 0U);
  EXPECT_GT(j["sslbp"]["errors"]["crc"].get<std::uint64_t>(), 0U) << j.dump();
  EXPECT_EQ(j["remote_crc_errors"], 0) << "nothing damaged on the way to the remote";
  EXPECT_EQ(get()["channels"][1]["did"]["bits_flipped"], 0);

  // A cut for a while, then back by itself; clear puts everything right.
  const auto cut = post({{"channel", 1}, {"cut_ms", 500}});
  EXPECT_GT(cut.second["channels"][1]["cut_for_ms"].get<double>(), 0.0);
  const auto cleared = post({{"channel", 0}, {"clear", true}});
  EXPECT_EQ(cleared.second["channels"][0]["set"]["from_remote"]["bit_error_rate"], 0.0);
  EXPECT_EQ(cleared.second["channels"][0]["connected"], true);
}

TEST_F(SimLink, TheCliSetsAndShowsALink) {
  const std::string api = "127.0.0.1:" + std::to_string(api_);
  auto r = test_support::run({"fault", "link", "channel=1", "bit_error_rate=1e-4", "break=true", "--api", api},
                                std::chrono::seconds(10));
  EXPECT_EQ(r.exit, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("\"bit_error_rate\": 0.0001"), std::string::npos) << r.out;
  r = test_support::run({"fault", "link", "--api", api}, std::chrono::seconds(10));
  EXPECT_EQ(r.exit, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("\"channels\""), std::string::npos) << r.out;
  r = test_support::run({"fault", "link", "channel=1", "bit_error_rate=2", "--api", api}, std::chrono::seconds(10));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE((r.out + r.err).find("bit_error_rate"), std::string::npos) << r.out << r.err;
}

TEST(LinkFaultScript, ALinkEntryTakesForAndEndsAsItWasBefore) {
  hm2::HostMot2Card card;
  server::SimClock clock(1.0, true);
  const server::ApiTarget t{card, clock, {}, nullptr, {}, nullptr, nullptr};
  server::FaultScript script(
      {{lbp::SimTime{10ms}, "link", json{{"channel", 0}, {"bit_error_rate", 1e-3}, {"seed", 3}}, lbp::SimTime{5ms},
        "f.toml:1:1"},
       {lbp::SimTime{20ms}, "link", json{{"channel", 1}, {"cut_ms", 100}}, lbp::SimTime{1ms}, "f.toml:7:1"}},
      hm2::HostMot2Card::Options{}, std::nullopt);
  auto log = [](const std::string&) {};
  auto& link0 = card.part<hm2::Sslbp>().link(0);
  script.runDue(lbp::SimTime{10ms}, t, log);
  EXPECT_EQ(link0.rates().toRemote.bitErrorRate, 1e-3);
  EXPECT_EQ(link0.rates().fromRemote.bitErrorRate, 1e-3);
  EXPECT_EQ(link0.rates().seed, 3U);
  script.runDue(lbp::SimTime{15ms}, t, log);
  EXPECT_EQ(link0.rates(), SerialLink::RateSettings{}) << "a clean cable again after its 5 ms";
  card.advance(lbp::SimTime{20ms});
  script.runDue(lbp::SimTime{20ms}, t, log);
  EXPECT_FALSE(card.part<hm2::Sslbp>().link(1).connectedAt(card.now()));
  card.advance(lbp::SimTime{21ms});
  script.runDue(lbp::SimTime{21ms}, t, log);
  EXPECT_TRUE(card.part<hm2::Sslbp>().link(1).connectedAt(card.now())) << "plugged back when the entry ended";

  // A mistake in an entry is an error before the sim starts.
  EXPECT_THROW(server::FaultScript({{lbp::SimTime{1ms}, "link", json{{"channel", 0}, {"bit_error_rate", -1}},
                                     std::nullopt, "f.toml:1:1"}},
                                   hm2::HostMot2Card::Options{}, std::nullopt),
               std::invalid_argument);
}

TEST(LinkFaultScript, OverlappingLinkEntriesEachUndoOnlyTheirOwnChange) {
  hm2::HostMot2Card card;
  server::SimClock clock(1.0, true);
  const server::ApiTarget t{card, clock, {}, nullptr, {}, nullptr, nullptr};
  auto log = [](const std::string&) {};
  server::FaultScript script(
      {{lbp::SimTime{0ms}, "link", json{{"channel", 0}, {"bit_error_rate", 1e-3}}, lbp::SimTime{300ms}, "f.toml:1:1"},
       {lbp::SimTime{100ms}, "link", json{{"channel", 0}, {"drop_rate", 1e-2}}, lbp::SimTime{1000ms}, "f.toml:6:1"}},
      hm2::HostMot2Card::Options{}, std::nullopt);
  auto& link0 = card.part<hm2::Sslbp>().link(0);
  script.runDue(lbp::SimTime{100ms}, t, log);
  EXPECT_EQ(link0.rates().fromRemote.bitErrorRate, 1e-3);
  EXPECT_EQ(link0.rates().fromRemote.dropRate, 1e-2);
  script.runDue(lbp::SimTime{300ms}, t, log);
  EXPECT_EQ(link0.rates().toRemote.bitErrorRate, 0.0) << "the bit errors ended";
  EXPECT_EQ(link0.rates().fromRemote.bitErrorRate, 0.0);
  EXPECT_EQ(link0.rates().toRemote.dropRate, 1e-2);
  script.runDue(lbp::SimTime{1100ms}, t, log);
  EXPECT_EQ(link0.rates(), SerialLink::RateSettings{}) << "a clean cable once both ended";
}

TEST(LinkFaultScript, TheFileTakesLinkEntriesWithFor) {
  const auto p = std::filesystem::temp_directory_path() / ("lbpkit-link-script-" + std::to_string(::getpid()) + ".toml");
  {
    std::ofstream f(p);
    f << "[[fault]]\nat = \"1s\"\nfault = \"link\"\nchannel = 0\nbit_error_rate = 1e-4\nfor = \"2s\"\n";
  }
  const auto script = config::loadFaultScript(p.string());
  std::filesystem::remove(p);
  ASSERT_EQ(script.size(), 1U);
  EXPECT_EQ(script[0].fault, "link");
  EXPECT_EQ(script[0].lasts, std::optional<std::chrono::nanoseconds>(2s));
  EXPECT_EQ(json::parse(script[0].body), (json{{"channel", 0}, {"bit_error_rate", 1e-4}}));
}

}  // namespace
