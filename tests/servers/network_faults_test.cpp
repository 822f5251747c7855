// SPDX-License-Identifier: MIT
// A bad network on purpose: the fault injector's decisions, the
// UDP server carrying them out on a real socket, and `lbpkit sim`'s
// /api/network.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "config/fault_script.hpp"
#include "config/toml_reader.hpp"
#include "daemon/fault_script.hpp"
#include "daemon/network_api.hpp"
#include "daemon/sim_clock.hpp"
#include "lbp16/network_faults.hpp"
#include "lbp16/udp_server.hpp"
#include "lbpkit/wire/lbp16.hpp"
#include "support/sim_child.hpp"
#include "support/wait.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace lbp = lbpkit::model::lbp;
namespace server = lbpkit::server;
namespace config = lbpkit::config;

namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using server::NetworkFaults;
using Kind = NetworkFaults::Kind;

TEST(NetworkFaults, AGoodNetworkPassesEverythingUntouched) {
  NetworkFaults f;
  const auto now = NetworkFaults::Clock::now();
  EXPECT_FALSE(f.active(now));
  for (int i = 0; i < 100; ++i) {
    const auto fate = f.decide(Kind::Request, 10, now);
    EXPECT_FALSE(fate.lost);
    EXPECT_EQ(fate.copies, 1U);
    EXPECT_EQ(fate.delay, 0us);
    EXPECT_EQ(fate.corruptAt, -1);
  }
  EXPECT_EQ(f.counters().request.passed, 100U);
}

TEST(NetworkFaults, DropEveryNthLosesExactlyThoseInThatDirectionOnly) {
  NetworkFaults f;
  server::NetworkFaultSettings s;
  s.reply.dropEvery = 4;
  f.set(s);
  const auto now = NetworkFaults::Clock::now();
  int lost = 0;
  for (int i = 1; i <= 100; ++i) {
    const bool l = f.decide(Kind::Reply, 10, now).lost;
    EXPECT_EQ(l, i % 4 == 0) << i;
    lost += l ? 1 : 0;
    EXPECT_FALSE(f.decide(Kind::Request, 10, now).lost);
  }
  EXPECT_EQ(lost, 25);
  EXPECT_EQ(f.counters().reply.dropped, 25U);
  EXPECT_EQ(f.counters().reply.passed, 75U);
  EXPECT_EQ(f.counters().request.dropped, 0U);
}

TEST(NetworkFaults, DropNextLosesThatManyThenPassesEverything) {
  NetworkFaults f;
  server::NetworkFaultSettings s;
  s.reply.dropNext = 2;
  f.set(s);
  const auto now = NetworkFaults::Clock::now();
  EXPECT_TRUE(f.active(now));
  EXPECT_FALSE(f.decide(Kind::Request, 10, now).lost);  // the other direction keeps its own
  EXPECT_TRUE(f.decide(Kind::Reply, 10, now).lost);
  EXPECT_TRUE(f.decide(Kind::Reply, 10, now).lost);
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(f.decide(Kind::Reply, 10, now).lost) << i;
  EXPECT_EQ(f.settings().reply.dropNext, 0U);  // spent, as /api/network then shows
  EXPECT_FALSE(f.active(now));
  EXPECT_EQ(f.counters().reply.dropped, 2U);
  EXPECT_EQ(f.counters().reply.passed, 10U);
}

TEST(NetworkFaults, DelayEveryNthDelaysOnlyThoseASpike) {
  NetworkFaults f;
  server::NetworkFaultSettings s;
  s.reply.delayUs = 800;
  s.reply.delayEvery = 3;
  f.set(s);
  const auto now = NetworkFaults::Clock::now();
  for (int i = 1; i <= 12; ++i) EXPECT_EQ(f.decide(Kind::Reply, 10, now).delay, i % 3 == 0 ? 800us : 0us) << i;
  EXPECT_EQ(f.counters().reply.delayed, 4U);
}

TEST(NetworkFaults, WritesOnlyLeavesRequestsThatAskForAReplyAlone) {
  namespace lbp16 = lbpkit::wire::lbp16;
  const std::uint16_t read = lbp16::hm2Read(1), write = lbp16::hm2Write(1);
  // hm2_eth's write: write commands back to back, no reply wanted.
  const std::vector<std::uint8_t> writes = {std::uint8_t(write), std::uint8_t(write >> 8), 0x00, 0x01, 1, 2, 3, 4,
                                            std::uint8_t(write), std::uint8_t(write >> 8), 0x04, 0x01, 5, 6, 7, 8};
  // A write then a read: the card answers the read.
  const std::vector<std::uint8_t> both = {std::uint8_t(write), std::uint8_t(write >> 8), 0x00, 0x01, 1, 2, 3, 4,
                                          std::uint8_t(read), std::uint8_t(read >> 8), 0x00, 0x01};
  EXPECT_FALSE(NetworkFaults::asksForReply(writes));
  EXPECT_TRUE(NetworkFaults::asksForReply(both));
  EXPECT_FALSE(NetworkFaults::asksForReply({}));

  NetworkFaults f;
  server::NetworkFaultSettings s;
  s.request.dropNext = 1;
  s.request.writesOnly = true;
  f.set(s);
  const auto now = NetworkFaults::Clock::now();
  EXPECT_FALSE(f.decide(Kind::Request, both.size(), now, NetworkFaults::asksForReply(both)).lost);
  EXPECT_TRUE(f.decide(Kind::Request, writes.size(), now, NetworkFaults::asksForReply(writes)).lost);
  EXPECT_FALSE(f.decide(Kind::Request, writes.size(), now, NetworkFaults::asksForReply(writes)).lost);
  EXPECT_EQ(f.counters().request.dropped, 1U);
  EXPECT_EQ(f.counters().request.passed, 2U);
}

TEST(NetworkFaults, TheSameSeedLosesTheSameDatagrams) {
  server::NetworkFaultSettings s;
  s.request.drop = 0.3;
  s.request.corrupt = 0.2;
  s.request.jitterUs = 500;
  s.seed = 42;
  NetworkFaults a, b;
  a.set(s);
  b.set(s);
  const auto now = NetworkFaults::Clock::now();
  int lost = 0;
  for (int i = 0; i < 1000; ++i) {
    const auto x = a.decide(Kind::Request, 64, now), y = b.decide(Kind::Request, 64, now);
    ASSERT_EQ(x.lost, y.lost) << i;
    ASSERT_EQ(x.corruptAt, y.corruptAt) << i;
    ASSERT_EQ(x.delay, y.delay) << i;
    ASSERT_LT(x.corruptAt, 64);
    ASSERT_LE(x.delay, 500us);
    lost += x.lost ? 1 : 0;
  }
  // 30 % of 1000, give or take what a fair coin does (5 sigma ~ 72).
  EXPECT_NEAR(lost, 300, 75);
  s.seed = 43;
  b.set(s);
  a.set(server::NetworkFaultSettings{s.request, s.reply, 42});
  int differ = 0;
  for (int i = 0; i < 100; ++i) differ += a.decide(Kind::Request, 64, now).lost != b.decide(Kind::Request, 64, now).lost;
  EXPECT_GT(differ, 0);
}

TEST(NetworkFaults, ACablePulledLosesEverythingUntilItIsBack) {
  NetworkFaults f;
  const auto t0 = NetworkFaults::Clock::now();
  f.silence(200ms, t0);
  EXPECT_TRUE(f.active(t0));
  EXPECT_EQ(f.silentFor(t0 + 50ms), 150ms);
  EXPECT_TRUE(f.decide(Kind::Request, 10, t0 + 10ms).lost);
  EXPECT_TRUE(f.decide(Kind::Reply, 10, t0 + 199ms).lost);
  EXPECT_FALSE(f.decide(Kind::Request, 10, t0 + 200ms).lost);
  EXPECT_EQ(f.counters().request.silenced, 1U);
  EXPECT_EQ(f.counters().reply.silenced, 1U);
  EXPECT_FALSE(f.active(t0 + 201ms));
}

TEST(NetworkApi, ABadFieldChangesNothingAndSaysWhich) {
  NetworkFaults f;
  const auto now = NetworkFaults::Clock::now();
  auto refused = [&](const json& body) {
    try {
      server::applyNetwork(f, body, now);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(refused({{"drop", 0.5}, {"delay_us", -1}}).find("\"delay_us\""), std::string::npos);
  EXPECT_EQ(f.settings().request.drop, 0.0);  // the good field was not applied either
  EXPECT_NE(refused({{"drop", 1.5}}).find("from 0 to 1"), std::string::npos);
  EXPECT_NE(refused({{"direction", "up"}}).find("\"direction\""), std::string::npos);
  EXPECT_NE(refused({{"delay_ms", 5}}).find("unknown key \"delay_ms\""), std::string::npos);
  EXPECT_NE(refused({{"writes_only", true}, {"drop_next", 1}}).find("\"direction\": \"request\""), std::string::npos);
  EXPECT_EQ(f.settings().request.dropNext, 0U);
  server::applyNetwork(f, {{"direction", "reply"}, {"drop", 0.25}, {"delay_us", 900}}, now);
  EXPECT_EQ(f.settings().reply.drop, 0.25);
  EXPECT_EQ(f.settings().reply.delayUs, 900U);
  EXPECT_EQ(f.settings().request.drop, 0.0);
  server::applyNetwork(f, {{"silent_ms", 100}}, now);
  EXPECT_EQ(f.silentFor(now), 100ms);
  server::applyNetwork(f, {{"clear", true}}, now);
  EXPECT_FALSE(f.active(now));
}

// A UDP server answering every request with its own bytes, through the
// network under test, served by a thread of its own.
class EchoServer {
 public:
  // The faults are set before the serving thread starts: from then on only
  // that thread touches them (as in the sim, where API jobs run on it).
  explicit EchoServer(const server::NetworkFaultSettings& faults) : server_("127.0.0.1", 0) {
    server_.faults().set(faults);
    thread_ = std::thread([this] {
      while (!stop_.load())
        server_.serveOnce(1ms, [](std::span<const std::uint8_t> in, std::span<std::uint8_t> out) {
          std::copy(in.begin(), in.end(), out.begin());
          return in.size();
        });
    });
  }
  ~EchoServer() {
    stop_ = true;
    thread_.join();
  }
  [[nodiscard]] std::uint16_t port() const { return server_.port(); }

 private:
  server::UdpServer server_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

class Client {
 public:
  explicit Client(std::uint16_t port) {
    fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_port = htons(port);
    ::inet_pton(AF_INET, "127.0.0.1", &sa.sin_addr);
    ::connect(fd_, reinterpret_cast<sockaddr*>(&sa), sizeof sa);
  }
  ~Client() { ::close(fd_); }
  void send(std::vector<std::uint8_t> bytes) { ::send(fd_, bytes.data(), bytes.size(), 0); }
  // The next datagram, or nothing within `limit`.
  std::vector<std::uint8_t> receive(std::chrono::milliseconds limit) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(limit.count())) <= 0) return {};
    std::vector<std::uint8_t> b(2048);
    const auto n = ::recv(fd_, b.data(), b.size(), 0);
    b.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
    return b;
  }

 private:
  int fd_ = -1;
};

TEST(UdpServerFaults, RepliesAreDelayedDuplicatedAndReorderedOnARealSocket) {
  server::NetworkFaultSettings s;
  s.reply.delayUs = 30'000;
  EchoServer echo(s);
  Client c(echo.port());
  const auto sent = std::chrono::steady_clock::now();
  c.send({1, 2, 3});
  // When it comes, not whether it is there at some look, tells the delay.
  const auto r = c.receive(1000ms);
  EXPECT_EQ(r, (std::vector<std::uint8_t>{1, 2, 3}));
  EXPECT_GE(std::chrono::steady_clock::now() - sent, 30ms);
}

TEST(UdpServerFaults, ADuplicatedReplyArrivesTwiceAndALostOneNever) {
  server::NetworkFaultSettings s;
  s.reply.duplicate = 1;
  s.request.dropEvery = 2;  // the second request is lost
  EchoServer echo(s);
  Client c(echo.port());
  c.send({7});
  EXPECT_EQ(c.receive(1000ms), std::vector<std::uint8_t>{7});
  EXPECT_EQ(c.receive(1000ms), std::vector<std::uint8_t>{7});
  c.send({8});
  EXPECT_TRUE(c.receive(100ms).empty());
  c.send({9});
  EXPECT_EQ(c.receive(1000ms), std::vector<std::uint8_t>{9});
}

TEST(UdpServerFaults, AReorderedReplyComesAfterTheNextOne) {
  server::NetworkFaultSettings s;
  s.reply.dropEvery = 0;
  s.reply.reorder = 1;  // every reply waits for the next: each overtakes the one before
  EchoServer echo(s);
  Client c(echo.port());
  c.send({1});
  EXPECT_TRUE(c.receive(50ms).empty()) << "the first reply is held until another passes";
  // Held behind {2}'s reply, which is itself held behind the next: the
  // first goes once it has been overtaken.
  c.send({2});
  EXPECT_EQ(c.receive(1000ms), std::vector<std::uint8_t>{1});
}

TEST(UdpServerFaults, ACorruptedReplyDiffersInOneByte) {
  server::NetworkFaultSettings s;
  s.reply.corrupt = 1;
  EchoServer echo(s);
  Client c(echo.port());
  const std::vector<std::uint8_t> sent{10, 20, 30, 40, 50, 60, 70, 80};
  c.send(sent);
  const auto r = c.receive(1000ms);
  ASSERT_EQ(r.size(), sent.size());
  int differ = 0;
  for (std::size_t i = 0; i < r.size(); ++i) differ += r[i] != sent[i];
  EXPECT_EQ(differ, 1);
}

// `lbpkit sim`: POST /api/network makes the card's replies late or lost,
// GET /api/network says what it did.
TEST(SimNetwork, TheApiSetsTheNetworkAndCountsWhatItDid) {
  const std::string address = "127.94." + std::to_string(::getpid() % 250) + ".1";
  test_support::SimChild sim(test_support::SimOptions{address, -1, "127.0.0.1", false, {}, {}});
  const int api = sim.apiPort();
  const int port = lbpkit::wire::lbp16::kPort;
  ASSERT_GT(api, 0);
  auto post = [&](const json& body) {
    auto r = sim.post("/api/network", body);
    return std::make_pair(r.status, r.body);
  };
  const auto bad = post({{"drop", 2}});
  EXPECT_EQ(bad.first, 400);
  EXPECT_NE(bad.second["error"].get<std::string>().find("\"drop\""), std::string::npos);
  const auto set = post({{"direction", "reply"}, {"drop_every", 2}});
  ASSERT_EQ(set.first, 200) << set.second.dump();
  EXPECT_EQ(set.second["set"]["reply"]["drop_every"], 2);

  // Read the IDROM's first word ten times: every second reply is lost.
  int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(static_cast<std::uint16_t>(port));
  ::inet_pton(AF_INET, address.c_str(), &sa.sin_addr);
  ::connect(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa);
  int answered = 0;
  for (int i = 0; i < 10; ++i) {
    const std::uint16_t cmd = lbpkit::wire::lbp16::hm2Read(1);
    const std::uint8_t req[4] = {static_cast<std::uint8_t>(cmd), static_cast<std::uint8_t>(cmd >> 8), 0x00, 0x01};
    ::send(fd, req, sizeof req, 0);
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 300) > 0) {
      std::uint8_t b[64];
      answered += ::recv(fd, b, sizeof b, 0) == 4 ? 1 : 0;
    }
  }
  ::close(fd);
  EXPECT_EQ(answered, 5);
  // The last request's reply is one of those dropped: nothing came back to
  // say the sim has counted it, so the count is awaited.
  EXPECT_TRUE(test_support::waitFor([&] { return sim.get("/api/network")["did"]["request"]["passed"] == 10; }, 5s));
  const auto j = sim.get("/api/network");
  ASSERT_TRUE(j.is_object());
  EXPECT_EQ(j["did"]["reply"]["dropped"], 5);
  EXPECT_EQ(j["did"]["reply"]["passed"], 5);
  EXPECT_EQ(j["did"]["request"]["passed"], 10);
  EXPECT_EQ(post({{"clear", true}}).second["set"]["reply"]["drop_every"], 0);
}

// --- Fault scripts: [[fault]] entries in the sim's TOML.

std::string writeToml(const std::string& name, const std::string& text) {
  const auto p = std::filesystem::temp_directory_path() / ("lbpkit-faults-" + name + "-" + std::to_string(::getpid()) + ".toml");
  std::ofstream(p) << text;
  return p.string();
}

TEST(FaultScriptFile, EntriesComeInTimeOrderWithTheirOtherKeysAsTheBody) {
  const auto path = writeToml("order", R"(
[[fault]]
at = "2.5s"
fault = "network"
drop = 0.01
for = "200ms"

[[fault]]
at = 0.25
fault = "input"
input = 3
on = true
)");
  const auto script = config::loadFaultScript(path);
  std::filesystem::remove(path);
  ASSERT_EQ(script.size(), 2U);
  EXPECT_EQ(script[0].fault, "input");
  EXPECT_EQ(script[0].at, 250ms);
  EXPECT_FALSE(script[0].lasts.has_value());
  EXPECT_EQ(json::parse(script[0].body), (json{{"input", 3}, {"on", true}}));
  EXPECT_EQ(script[1].fault, "network");
  EXPECT_EQ(script[1].at, 2500ms);
  EXPECT_EQ(script[1].lasts, std::optional<std::chrono::nanoseconds>(200ms));
  EXPECT_EQ(json::parse(script[1].body), (json{{"drop", 0.01}}));
  EXPECT_NE(script[1].where.find(":2:1"), std::string::npos) << script[1].where;
}

TEST(FaultScriptFile, AMistakeNamesTheFileTheLineAndTheKey) {
  auto error = [](const std::string& text) {
    const auto path = writeToml("bad", text);
    std::string what;
    try {
      (void)config::loadFaultScript(path);
    } catch (const config::FileError& e) {
      what = e.what();
    }
    std::filesystem::remove(path);
    return what;
  };
  EXPECT_NE(error("[[fault]]\nat = \"5 parsecs\"\nfault = \"cable\"\n").find(":2:6: fault[0].at: \"5 parsecs\" is not a duration"),
            std::string::npos);
  EXPECT_NE(error("[[fault]]\nfault = \"cable\"\n").find("fault[0].at"), std::string::npos);
  EXPECT_NE(error("[[fault]]\nat = 1\nfault = \"lightning\"\n").find("fault[0].fault"), std::string::npos);
  EXPECT_NE(error("[[fault]]\nat = 1\nfault = \"input\"\ninput = 1\non = true\nfor = \"1s\"\n")
                .find("does not end by itself"),
            std::string::npos);
  EXPECT_NE(error("[[fault]]\nat = -1\nfault = \"cable\"\n").find("fault[0].at"), std::string::npos);
  // A duration is a decimal number and its unit: no hex float, no inf.
  for (const char* d : {"0x1p3s", "infs", "nan", " 2s", "+2s", "2.5.1s"})
    EXPECT_NE(error(std::string("[[fault]]\nat = \"") + d + "\"\nfault = \"cable\"\nchannel = 1\nconnected = false\n")
                  .find("is not a duration"),
              std::string::npos)
        << d;
  EXPECT_EQ(error("[[fault]]\nat = \"1.5e3ms\"\nfault = \"cable\"\nchannel = 1\nconnected = false\n"), "");
}

TEST(FaultScript, EveryEntryIsTriedBeforeTheSimStarts) {
  std::vector<server::ScriptedFault> entries{
      {lbp::SimTime{1ms}, "cable", json{{"channel", 1}, {"connected", false}}, std::nullopt, "f.toml:1:1"},
      {lbp::SimTime{2ms}, "network", json{{"delay_ms", 5}}, std::nullopt, "f.toml:6:1"}};
  try {
    server::FaultScript script(entries, hm2::HostMot2Card::Options{}, std::nullopt);
    ADD_FAILURE() << "a script with an unknown key was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("f.toml:6:1: fault \"network\": unknown key \"delay_ms\""),
              std::string::npos)
        << e.what();
  }
  entries[1].body = json{{"delay_us", 5}};
  entries.push_back({lbp::SimTime{3ms}, "machine", json{{"action", "estop"}, {"pressed", true}}, std::nullopt, "f.toml:9:1"});
  EXPECT_THROW(server::FaultScript(entries, hm2::HostMot2Card::Options{}, std::nullopt), std::invalid_argument)
      << "no machine to press the E-stop of";
}

TEST(FaultScript, EntriesAndTheirEndsHappenAtTheirSimulatedTimes) {
  hm2::HostMot2Card card;
  server::SimClock clock(1.0, true);
  server::UdpServer udp("127.0.0.1", 0);
  const server::ApiTarget t{card, clock, {}, nullptr, {}, nullptr, &udp};
  server::FaultScript script(
      {{lbp::SimTime{10ms}, "cable", json{{"channel", 1}, {"connected", false}}, lbp::SimTime{5ms}, "f.toml:1:1"},
       {lbp::SimTime{12ms}, "network", json{{"drop", 1}}, lbp::SimTime{1ms}, "f.toml:6:1"},
       {lbp::SimTime{20ms}, "overtemp", json{{"chip", 1}, {"hot", true}}, std::nullopt, "f.toml:11:1"}},
      hm2::HostMot2Card::Options{}, std::nullopt);
  std::vector<std::string> said;
  auto log = [&](const std::string& s) { said.push_back(s); };
  auto& link = card.part<hm2::Sslbp>().link(1);
  script.runDue(lbp::SimTime{9ms}, t, log);
  EXPECT_TRUE(link.connected());
  script.runDue(lbp::SimTime{10ms}, t, log);
  EXPECT_FALSE(link.connected());
  script.runDue(lbp::SimTime{12ms}, t, log);
  EXPECT_EQ(udp.faults().settings().request.drop, 1.0);
  script.runDue(lbp::SimTime{13ms}, t, log);
  EXPECT_EQ(udp.faults().settings().request.drop, 0.0) << "back to a good network after its 1 ms";
  EXPECT_FALSE(link.connected());
  script.runDue(lbp::SimTime{15ms}, t, log);
  EXPECT_TRUE(link.connected()) << "the cable back in after its 5 ms";
  EXPECT_EQ(script.done(), 2U);
  script.runDue(lbp::SimTime{1s}, t, log);
  EXPECT_EQ(script.done(), 3U);
  EXPECT_EQ(said.size(), 5U);
  EXPECT_NE(said.front().find("f.toml:1:1: cable"), std::string::npos) << said.front();
}

// Entries that overlap each take away only their own change, whichever
// ends first: a later entry that began while an earlier one was on does not
// put the earlier one's fault back when it ends.
TEST(FaultScript, OverlappingEntriesEachUndoOnlyTheirOwnChange) {
  hm2::HostMot2Card card;
  server::SimClock clock(1.0, true);
  server::UdpServer udp("127.0.0.1", 0);
  const server::ApiTarget t{card, clock, {}, nullptr, {}, nullptr, &udp};
  auto log = [](const std::string&) {};
  // drop 0.5 for 300 ms, then duplicate 0.25 for 1 s from 100 ms: the later
  // one ends last.
  server::FaultScript later(
      {{lbp::SimTime{0ms}, "network", json{{"drop", 0.5}}, lbp::SimTime{300ms}, "f.toml:1:1"},
       {lbp::SimTime{100ms}, "network", json{{"duplicate", 0.25}}, lbp::SimTime{1000ms}, "f.toml:6:1"}},
      hm2::HostMot2Card::Options{}, std::nullopt);
  later.runDue(lbp::SimTime{100ms}, t, log);
  EXPECT_EQ(udp.faults().settings().reply.drop, 0.5);
  EXPECT_EQ(udp.faults().settings().reply.duplicate, 0.25);
  later.runDue(lbp::SimTime{300ms}, t, log);
  EXPECT_EQ(udp.faults().settings().request.drop, 0.0) << "the drop ended";
  EXPECT_EQ(udp.faults().settings().request.duplicate, 0.25);
  later.runDue(lbp::SimTime{1100ms}, t, log);
  EXPECT_EQ(udp.faults().settings(), server::NetworkFaultSettings{}) << "a good network once both ended";

  // The same setting twice: drop 0.5 for 300 ms, drop 0.2 from 100 ms for
  // 100 ms (ends first, back to 0.5), then drop 0.9 from 250 ms for 1 s
  // (outlives the first, which then changes nothing).
  server::FaultScript same({{lbp::SimTime{0ms}, "network", json{{"drop", 0.5}}, lbp::SimTime{300ms}, "f.toml:1:1"},
                            {lbp::SimTime{100ms}, "network", json{{"drop", 0.2}}, lbp::SimTime{100ms}, "f.toml:6:1"},
                            {lbp::SimTime{250ms}, "network", json{{"drop", 0.9}, {"direction", "reply"}},
                             lbp::SimTime{1000ms}, "f.toml:11:1"}},
                           hm2::HostMot2Card::Options{}, std::nullopt);
  same.runDue(lbp::SimTime{100ms}, t, log);
  EXPECT_EQ(udp.faults().settings().request.drop, 0.2);
  same.runDue(lbp::SimTime{200ms}, t, log);
  EXPECT_EQ(udp.faults().settings().request.drop, 0.5) << "back to the entry still on";
  same.runDue(lbp::SimTime{250ms}, t, log);
  EXPECT_EQ(udp.faults().settings().reply.drop, 0.9);
  same.runDue(lbp::SimTime{300ms}, t, log);
  EXPECT_EQ(udp.faults().settings().request.drop, 0.0) << "the first one ended: requests as before it";
  EXPECT_EQ(udp.faults().settings().reply.drop, 0.9) << "replies keep the entry still on";
  same.runDue(lbp::SimTime{1250ms}, t, log);
  EXPECT_EQ(udp.faults().settings(), server::NetworkFaultSettings{});
}

}  // namespace
