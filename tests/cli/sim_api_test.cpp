// SPDX-License-Identifier: MIT
// `lbpkit sim` under attack and misuse: its HTTP control API, its
// shutdown, its card thread under load, and what it reports. Each test
// starts its own sim on a loopback address of its own, talks to it over
// plain sockets (so it can misbehave as a hostile client would), and stops
// it before it ends.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <sstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "daemon/sim_clock.hpp"
#include "hostmot2/muxed_encoder.hpp"
#include "lbpkit/hostmot2.hpp"
#include "lbpkit/lbp16_transport.hpp"
#include "lbpkit/sserial.hpp"
#include "lbpkit/wire/lbp16.hpp"
#include "support/process.hpp"
#include "support/sim_child.hpp"
#include "support/temp_dir.hpp"
#include "support/wait.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using test_support::Daemon;
using Clock = std::chrono::steady_clock;

// A loopback address of this test's own: 127.93.P.n, P from the process id
// (ctest runs tests side by side), n per test.
std::string loopback(int n) { return "127.93." + std::to_string(::getpid() % 250) + "." + std::to_string(n); }

// Files of this test process's own (state files, recordings), in a folder
// that goes with the process.
std::string tempPath(const std::string& name) {
  static const test_support::TempDir folder("lbpkit-simapi");
  auto p = folder / name;
  std::filesystem::remove(p);
  return p;
}

// A TCP connection to the API, closed when it goes.
class Conn {
 public:
  Conn(const std::string& address, int port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_port = htons(static_cast<std::uint16_t>(port));
    ::inet_pton(AF_INET, address.c_str(), &sa.sin_addr);
    ok_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&sa), sizeof sa) == 0;
    const int on = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
  }
  ~Conn() {
    if (fd_ >= 0) ::close(fd_);
  }
  Conn(const Conn&) = delete;
  Conn& operator=(const Conn&) = delete;
  [[nodiscard]] bool ok() const { return ok_; }
  bool send(const std::string& s) {
    std::size_t at = 0;
    while (at < s.size()) {
      const ssize_t n = ::send(fd_, s.data() + at, s.size() - at, MSG_NOSIGNAL);
      if (n <= 0) return false;
      at += static_cast<std::size_t>(n);
    }
    return true;
  }
  // Everything until the server closes, or `limit`.
  std::string readAll(std::chrono::milliseconds limit) {
    std::string out;
    const auto end = Clock::now() + limit;
    while (Clock::now() < end) {
      pollfd p{fd_, POLLIN, 0};
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count();
      if (::poll(&p, 1, static_cast<int>(std::max<long long>(left, 1))) <= 0) continue;
      char buf[65536];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) break;
      out.append(buf, static_cast<std::size_t>(n));
    }
    return out;
  }

 private:
  int fd_ = -1;
  bool ok_ = false;
};

struct Reply {
  int status = 0;  // 0: no answer
  json body;
  std::string raw;
  std::chrono::milliseconds took{0};
};

Reply parse(const std::string& raw) {
  Reply r;
  r.raw = raw;
  if (raw.rfind("HTTP/1.", 0) == 0 && raw.size() > 12) r.status = std::atoi(raw.c_str() + 9);
  const auto at = raw.find("\r\n\r\n");
  if (at != std::string::npos) r.body = json::parse(raw.substr(at + 4), nullptr, false);
  return r;
}

struct Request {
  std::string method = "GET";
  std::string path = "/api/state";
  std::string body;
  std::string contentType = "application/json";
  std::optional<std::string> host;  // default: the API's own address:port
  std::vector<std::string> headers;
};

Reply http(const std::string& address, int port, const Request& q, std::chrono::milliseconds limit = 3000ms) {
  const auto start = Clock::now();
  Conn c(address, port);
  if (!c.ok()) return {};
  std::string s = q.method + " " + q.path + " HTTP/1.1\r\n";
  s += "Host: " + q.host.value_or(address + ":" + std::to_string(port)) + "\r\n";
  for (const auto& h : q.headers) s += h + "\r\n";
  if (q.method == "POST") {
    if (!q.contentType.empty()) s += "Content-Type: " + q.contentType + "\r\n";
    s += "Content-Length: " + std::to_string(q.body.size()) + "\r\n";
  }
  s += "Connection: close\r\n\r\n" + q.body;
  c.send(s);
  Reply r = parse(c.readAll(limit));
  r.took = std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - start);
  return r;
}

// `lbpkit sim` on ADDRESS (LBP16 and API on free ports), its own state,
// asked over a raw HTTP connection: what is tested is the API's own answer,
// byte for byte.
class Sim : public test_support::SimChild {
 public:
  using SimChild::SimChild;
  Reply get(const std::string& path = "/api/state", std::chrono::milliseconds limit = 3000ms) {
    Request q;
    q.path = path;
    return send(q, limit);
  }
  Reply post(const std::string& path, const json& body, std::chrono::milliseconds limit = 3000ms) {
    Request q;
    q.method = "POST";
    q.path = path;
    q.body = body.dump();
    return send(q, limit);
  }
  Reply send(const Request& q, std::chrono::milliseconds limit = 3000ms) {
    return http(address(), apiPort(), q, limit);
  }
};

// --- The sim on the LBP16 port, as lbpkit's own tools and the API see it --------

// `lbpkit sim` on the port hm2_eth and mesaflash use (27181), on an address
// of this test's own, its API on 127.0.0.1.
test_support::SimOptions onLbp16Port(int n) { return {loopback(n), -1, "127.0.0.1", true, {}, {}}; }

TEST(Lbp16, GarbageFromAnotherPortDoesNotStopService) {
  test_support::SimChild sim(onLbp16Port(19));
  ASSERT_TRUE(sim.up());
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(27181);
  ::inet_pton(AF_INET, sim.address().c_str(), &sa.sin_addr);
  std::uint32_t x = 7;
  std::vector<std::uint8_t> junk(3000);
  for (int i = 0; i < 2000; ++i) {
    for (auto& b : junk) b = static_cast<std::uint8_t>((x = x * 1103515245U + 12345U) >> 16);
    const std::size_t len = 1 + (x % junk.size());
    ::sendto(fd, junk.data(), len, 0, reinterpret_cast<sockaddr*>(&sa), sizeof sa);
  }
  ::close(fd);
  std::this_thread::sleep_for(100ms);
  const auto s = sim.get();
  ASSERT_FALSE(s.is_null());
  EXPECT_GT(s["lbp16"]["parse_errors"].get<int>(), 0);
  // A legitimate client is still served.
  const auto r = test_support::run({"rpd", "nvunitnumber", "H", "--addr", sim.address()});
  EXPECT_EQ(r.exit, 0) << r.err;
  EXPECT_EQ(r.out, "12000AEE\n");
}

TEST(ControlApi, ChangesTheWorldAndRefusesBadRequests) {
  test_support::SimChild sim(onLbp16Port(20));
  ASSERT_TRUE(sim.up());
  auto s = sim.post("/api/input", {{"input", 4}, {"volts", 20.0}}).body;
  EXPECT_EQ(s["daughtercards"][0]["field_io"]["inputs"][4]["on"], true);
  s = sim.post("/api/output", {{"output", 2}, {"ohms", 80.0}}).body;
  EXPECT_FALSE(s.contains("error"));
  s = sim.post("/api/field", {{"volts", 36.0}}).body;
  const auto faults = s["daughtercards"][0]["field_io"]["faults"];
  EXPECT_NE(std::find(faults.begin(), faults.end(), "HighVoltageFault"), faults.end()) << faults.dump();
  s = sim.post("/api/cable", {{"channel", 1}, {"connected", false}}).body;
  EXPECT_EQ(s["sserial"]["channels"][1]["cable_connected"], false);
  s = sim.post("/api/time", {{"paused", true}}).body;
  const double t0 = s["time_s"].get<double>();
  std::this_thread::sleep_for(50ms);
  EXPECT_EQ(sim.get()["time_s"].get<double>(), t0);
  s = sim.post("/api/time", {{"step_ms", 100}}).body;
  EXPECT_NEAR(s["time_s"].get<double>() - t0, 0.1, 1e-6);
  // Bad requests: 400 with a message, and the card keeps running.
  EXPECT_NE(sim.post("/api/input", {{"input", 40}, {"on", true}}).body["error"].get<std::string>().find("below 32"),
            std::string::npos);
  EXPECT_NE(sim.post("/api/input", {{"on", true}}).body["error"].get<std::string>().find("missing \"input\""),
            std::string::npos);
  EXPECT_NE(sim.post("/api/time", {{"speed", 0}}).body["error"].get<std::string>().find("above 0"), std::string::npos);
  EXPECT_NE(sim.post("/api/encoder", {{"encoder", "two"}}).body["error"].get<std::string>().size(), 0U);
  EXPECT_FALSE(sim.get().is_null());
}

// --- LBP16 datagrams, as hm2_eth and mesaflash send them

namespace lbp16 = lbpkit::wire::lbp16;
using Bytes = std::vector<std::uint8_t>;

void command(Bytes& d, lbp16::Command c, std::uint16_t address) {
  c.hasAddress = true;
  const auto w = c.encode();
  d.insert(d.end(), {static_cast<std::uint8_t>(w), static_cast<std::uint8_t>(w >> 8), static_cast<std::uint8_t>(address),
                     static_cast<std::uint8_t>(address >> 8)});
}

void put16(Bytes& d, std::uint16_t v) { d.insert(d.end(), {static_cast<std::uint8_t>(v), static_cast<std::uint8_t>(v >> 8)}); }

void put32(Bytes& d, std::uint32_t v) {
  put16(d, static_cast<std::uint16_t>(v));
  put16(d, static_cast<std::uint16_t>(v >> 16));
}

// Sends `d` and returns the reply (empty when none came within 1 s).
Bytes exchange(const std::string& address, int port, const Bytes& d) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(static_cast<std::uint16_t>(port));
  ::inet_pton(AF_INET, address.c_str(), &sa.sin_addr);
  ::sendto(fd, d.data(), d.size(), 0, reinterpret_cast<sockaddr*>(&sa), sizeof sa);
  Bytes reply(1500);
  pollfd p{fd, POLLIN, 0};
  ssize_t n = -1;
  if (::poll(&p, 1, 1000) > 0) n = ::recv(fd, reply.data(), reply.size(), 0);
  ::close(fd);
  reply.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
  return reply;
}

// A cookie read at the end of a datagram: its reply says the card took the
// whole datagram.
void cookieRead(Bytes& d) { command(d, {false, true, false, 0, 4, true, 1}, 0x0100); }

// --- The control API's limits -------------------------------------------

// Slow-loris clients (a header byte every 2 s) and a hundred idle connections
// used to hold every one of httplib's threads: the API answered nobody for
// as long as they stayed.
TEST(SimApi, SlowAndIdleClientsDoNotLockOthersOut) {
  Sim sim(loopback(1));
  ASSERT_TRUE(sim.up());
  std::vector<std::unique_ptr<Conn>> loris, idle;
  const std::string head = "GET /api/state HTTP/1.1\r\nHost: " + sim.address() + "\r\n";
  for (int i = 0; i < 8; ++i) {
    loris.push_back(std::make_unique<Conn>(sim.address(), sim.apiPort()));
    loris.back()->send(head.substr(0, 1));
  }
  for (int i = 0; i < 100; ++i) idle.push_back(std::make_unique<Conn>(sim.address(), sim.apiPort()));
  std::atomic<bool> done{false};
  std::thread drip([&] {
    for (std::size_t k = 1; !done; ++k) {
      for (int t = 0; t < 200 && !done; ++t) std::this_thread::sleep_for(10ms);  // 2 s
      for (auto& c : loris) c->send(head.substr(k % head.size(), 1));
    }
  });
  std::this_thread::sleep_for(300ms);  // all of them connected and waiting
  for (int round = 0; round < 3; ++round) {
    const auto r = sim.get("/api/state", 2000ms);
    EXPECT_EQ(r.status, 200) << "round " << round << ": " << r.raw.substr(0, 200);
    EXPECT_LT(r.took.count(), 1000) << "round " << round;
    std::this_thread::sleep_for(700ms);
  }
  done = true;
  drip.join();
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

// A body over the limit is refused without being kept (three 100 MB posts
// took the daemon to 2 GB).
TEST(SimApi, OversizedBodiesAreRefusedWith413) {
  Sim sim(loopback(2));
  ASSERT_TRUE(sim.up());
  Request q;
  q.method = "POST";
  q.path = "/api/time";
  q.body = "{\"speed\": 1, \"pad\": \"" + std::string(2 * 1024 * 1024, 'x') + "\"}";
  const auto r = sim.send(q);
  EXPECT_EQ(r.status, 413) << r.raw.substr(0, 300);
  ASSERT_TRUE(r.body.is_object()) << r.raw.substr(0, 300);
  EXPECT_NE(r.body.value("error", "").find("too large"), std::string::npos) << r.body;
  // A body of unknown length is refused too: it could be any size.
  Conn c(sim.address(), sim.apiPort());
  c.send("POST /api/time HTTP/1.1\r\nHost: " + sim.address() + ":" + std::to_string(sim.apiPort()) +
         "\r\nContent-Type: application/json\r\nTransfer-Encoding: chunked\r\n\r\n2\r\n{}\r\n0\r\n\r\n");
  const auto rc = parse(c.readAll(2000ms));
  EXPECT_EQ(rc.status, 411) << rc.raw;
  // And the API still works.
  EXPECT_EQ(sim.get().status, 200);
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

// httplib set SO_REUSEPORT: a second sim shared the first one's API port and
// requests landed on either.
// The kernel's PM QoS CPU latency request as it stands: the lowest any
// process holds, 2000 s (no limit) when none does.
std::optional<std::int32_t> cpuLatencyUs() {
  std::ifstream f("/dev/cpu_dma_latency", std::ios::binary);
  std::int32_t us = 0;
  if (!f.read(reinterpret_cast<char*>(&us), sizeof us)) return std::nullopt;
  return us;
}

// Whether process pid has /dev/cpu_dma_latency open: a PM QoS request
// lasts as long as the file is open (kernel: Documentation/power/pm_qos_interface.rst).
bool holdsCpuLatencyRequest(pid_t pid) {
  std::error_code ec;
  for (const auto& fd : std::filesystem::directory_iterator("/proc/" + std::to_string(pid) + "/fd", ec))
    if (std::filesystem::read_symlink(fd.path(), ec) == "/dev/cpu_dma_latency") return true;
  return false;
}

TEST(SimApi, CpuLatencyHoldsTheMachinesWakeUpLatencyWhileTheSimRuns) {
  if (!cpuLatencyUs() || ::geteuid() != 0) GTEST_SKIP() << "needs root and /dev/cpu_dma_latency";
  {
    Sim sim(loopback(21), {"--cpu-latency", "0"});
    ASSERT_TRUE(sim.up());
    const auto state = sim.get();
    ASSERT_TRUE(state.body.is_object());
    EXPECT_NE(state.body["server"]["scheduling"].get<std::string>().find("CPU wake-up latency held at 0 us"),
              std::string::npos)
        << state.body["server"]["scheduling"];
    // The kernel keeps the lowest request any process holds, so the value
    // read is 0 whoever else holds one (lbpkit bench's sims do); that the
    // request is this sim's shows in its open files. The kernel drops it
    // when the file closes, at the latest when the sim exits.
    EXPECT_EQ(cpuLatencyUs(), 0);
    EXPECT_TRUE(holdsCpuLatencyRequest(sim.pid())) << "the sim holds no /dev/cpu_dma_latency request";
    EXPECT_EQ(sim.stop(), 0);
  }
}

TEST(SimApi, ASecondSimOnTheSameApiPortIsRefused) {
  Sim first(loopback(3));
  ASSERT_TRUE(first.up());
  const auto api = first.address() + ":" + std::to_string(first.apiPort());
  const auto state = tempPath("second");
  const auto r = test_support::run(
      {"sim", "--bind", loopback(4) + ":0", "--no-realtime", "--state", state, "--api", api}, std::chrono::seconds(5));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("control API port " + api + " is in use (another lbpkit sim?)"), std::string::npos) << r.err;
  test_support::removeStateFiles(state);
  EXPECT_EQ(first.get().status, 200);
  EXPECT_EQ(first.stopWithin(2000ms), 0);
}

// --- Stopping whatever clients do ---------------------------------------

// One slow client kept the sim running (not answering, holding its ports)
// for as long as it dripped.
TEST(SimApi, SigtermAndSigintStopTheSimWhateverClientsDo) {
  for (const int sig : {SIGTERM, SIGINT}) {
    Sim sim(loopback(5));
    ASSERT_TRUE(sim.up());
    Conn slow(sim.address(), sim.apiPort());
    Conn idle(sim.address(), sim.apiPort());
    const std::string head = "GET /api/state HTTP/1.1\r\n";
    std::atomic<bool> done{false};
    std::thread drip([&] {
      for (std::size_t k = 0; !done && k < head.size(); ++k) {
        slow.send(head.substr(k, 1));
        std::this_thread::sleep_for(200ms);
      }
    });
    std::this_thread::sleep_for(700ms);
    EXPECT_EQ(sim.stopWithin(2000ms, sig), 0) << "signal " << sig;
    done = true;
    drip.join();
  }
}

// How often the card thread (the sim's main thread) has slept and woken:
// its voluntary context switches (proc(5)). The kernel counts one when the
// thread goes to sleep, not when it wakes: a thread that has just answered
// a job is counted only once it sleeps again.
long cardThreadWakeUps(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/task/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("voluntary_ctxt_switches:", 0) == 0) return std::stol(line.substr(line.find(':') + 1));
  return -1;
}

// A card nobody talks to has nothing to do: its thread sleeps until a
// datagram or an API request comes (a sim waking every millisecond cost
// about 3 % of a core on this project's machine; docs/performance.md), and
// a request or a signal still wakes it at once.
TEST(SimApi, ACardNobodyTalksToSleepsUntilADatagramOrARequest) {
  Sim sim(loopback(5));
  ASSERT_TRUE(sim.up());
  ASSERT_EQ(sim.get().status, 200);
  const long before = cardThreadWakeUps(sim.pid());
  ASSERT_GE(before, 0);
  std::this_thread::sleep_for(500ms);
  const long asleep = cardThreadWakeUps(sim.pid()) - before;
  // Woken every millisecond it would be about 500.
  EXPECT_LE(asleep, 5) << "the card thread woke " << asleep << " times in 500 ms with nothing to do";
  // A request is a job for the card thread: answered, so it woke for it.
  ASSERT_EQ(sim.get().status, 200);
  // It is counted once it sleeps again, which may come after the reply.
  EXPECT_TRUE(test_support::waitFor([&] { return cardThreadWakeUps(sim.pid()) > before + asleep; }, 2s))
      << "the card thread did not sleep again after answering the request";
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

// A machine nobody talks to only moves, and its plant is exact over any
// span: the card thread catches it up four times a second at speed 1
// (SimDaemon::kMachineTick of simulated time, SimClock::wallFor at other
// speeds) instead of every millisecond, and whoever looks sees it current.
TEST(SimApi, AMachineNobodyTalksToWakesTheCardFourTimesASecond) {
  Sim sim(loopback(20), {"--machine", "mill"});
  ASSERT_TRUE(sim.up());
  // Simulated time plus what it fell behind the wall clock (a catch-up cut
  // short by its budget on a busy machine sets the clock back and counts
  // it): together they are the wall time the sim has run, whatever the load.
  const auto ran = [&] {
    const auto state = sim.get("/api/state").body;
    return state["time_s"].get<double>() + state["clock"]["behind_ms"].get<double>() / 1000.0;
  };
  const double t0 = ran();
  const long before = cardThreadWakeUps(sim.pid());
  ASSERT_GE(before, 0);
  std::this_thread::sleep_for(1000ms);
  const long woke = cardThreadWakeUps(sim.pid()) - before;
  // Every millisecond it would be about 1000.
  EXPECT_LE(woke, 10) << "the card thread woke " << woke << " times in 1 s with a machine and no host";
  EXPECT_GE(woke, 2) << "it still catches the machine up";
  // A look catches the machine up to the moment it is asked at.
  EXPECT_GE(ran() - t0, 0.999);
  // Faster than the wall clock it looks as often in simulated time: at
  // speed 100 every 2 ms of wall time (about 400 times a second), so that
  // each catch-up stays short.
  ASSERT_EQ(sim.post("/api/time", {{"speed", 100}}).status, 200);
  const long fast = cardThreadWakeUps(sim.pid());
  std::this_thread::sleep_for(1000ms);
  const long wokeFast = cardThreadWakeUps(sim.pid()) - fast;
  EXPECT_GE(wokeFast, 100) << "the card thread woke " << wokeFast << " times in 1 s at speed 100";
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

// `lbpkit sim --bind A --bind B`: a card on each address, one process and
// one card thread for both, each card with its own API on its own address
// and its own EEPROM (in --state's folder, named by its address).
TEST(SimApi, OneProcessServesACardOnEachBindAddress) {
  test_support::TempDir folder("lbpkit-cards");
  const std::string a = loopback(40), b = loopback(41);
  test_support::Daemon sim({"sim", "--bind", a + ":0", "--bind", b + ":0", "--api", "0", "--no-realtime", "--state",
                            folder.path().string(), "--ready-fd", "3"},
                           true);
  // Its greeting names both cards, once both serve.
  const auto cards = test_support::greeting(sim)["cards"];
  ASSERT_EQ(cards.size(), 2U) << cards.dump();
  EXPECT_EQ(cards[0]["lbp16"]["address"], a);
  EXPECT_EQ(cards[1]["lbp16"]["address"], b);
  EXPECT_EQ(cards[0]["api"]["address"], a);
  const int portA = cards[0]["lbp16"]["port"].get<int>();
  const int apiA = cards[0]["api"]["port"].get<int>();
  const int portB = cards[1]["lbp16"]["port"].get<int>();
  const int apiB = cards[1]["api"]["port"].get<int>();
  ASSERT_NE(sim.readUntil("2 cards, served by one thread").find("served by one thread"), std::string::npos);
  ASSERT_GT(portA, 0);
  ASSERT_GT(portB, 0);
  // Each answers LBP16 on its own socket, and its API says which it is.
  for (const auto& [address, port, api] : {std::tuple{a, portA, apiA}, std::tuple{b, portB, apiB}}) {
    const auto r = test_support::run({"info", "--addr", address + ":" + std::to_string(port)});
    EXPECT_EQ(r.exit, 0) << r.err;
    EXPECT_NE(r.out.find("MESA7I92 (LBP16 at " + address), std::string::npos) << r.out;
    const auto state = test_support::httpGetJson(address, api, "/api/state");
    ASSERT_FALSE(state.is_null()) << address;
    EXPECT_EQ(state["card"]["address"], address);
    EXPECT_EQ(state["server"]["datagrams"].get<std::uint64_t>() > 0, true) << address;
  }
  // Both stop on one signal; each kept its own EEPROM.
  EXPECT_EQ(sim.stopWithin(5000ms), 0);
  std::size_t eeproms = 0;
  for (const auto& f : std::filesystem::directory_iterator(folder.path()))
    if (f.path().extension() == ".eeprom") ++eeproms;
  EXPECT_EQ(eeproms, 2U);
  // What names one file or terminal is refused with several cards.
  const auto refused = test_support::run({"sim", "--bind", a + ":0", "--bind", b + ":0", "--record", "x.csv"});
  EXPECT_NE(refused.exit, 0);
  EXPECT_NE(refused.err.find("--record names one card's file"), std::string::npos) << refused.err;
}

// The files in `folder`, each with its bytes.
std::map<std::string, std::string> filesIn(const std::filesystem::path& folder) {
  std::map<std::string, std::string> out;
  for (const auto& f : std::filesystem::directory_iterator(folder)) {
    std::ifstream in(f.path(), std::ios::binary);
    out[f.path().filename().string()] = std::string(std::istreambuf_iterator<char>(in), {});
  }
  return out;
}

// Two --bind of one address and port clash on the command line: refused,
// naming both, before a socket or a file is opened.
TEST(SimApi, TwoBindsOfOneAddressAndPortAreRefusedNamingBoth) {
  test_support::TempDir folder("lbpkit-cards");
  const std::string a = loopback(42), b = loopback(43);
  for (const auto& [first, second, says] :
       {std::tuple{a + ":27181", a + ":27181", "are one address and port"}, std::tuple{a + ":0", a + ":0", "are one address and port"},
        std::tuple{a, a + ":27181", "are one address and port"},
        std::tuple{std::string("0.0.0.0:27181"), b + ":27181", "0.0.0.0 takes port 27181 on every address"}}) {
    const auto r = test_support::run(
        {"sim", "--bind", first, "--bind", b + ":0", "--bind", second, "--api", "0", "--no-realtime", "--state",
         folder.path().string()},
        std::chrono::seconds(10));
    EXPECT_EQ(r.exit, 1) << first << " " << second << "\n" << r.out << r.err;
    EXPECT_NE(r.err.find("--bind " + first + " and --bind " + second + " (options 1 and 3 of --bind)"),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find(says), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("another card"), std::string::npos) << r.err;
    EXPECT_TRUE(filesIn(folder.path()).empty()) << first;
  }
}

// An address that is not a dotted quad is refused, naming it, before any
// file is written: with one card and with several.
TEST(SimApi, AnInvalidBindAddressIsRefusedAndWritesNothing) {
  test_support::TempDir folder("lbpkit-cards");
  const auto state = (folder.path() / "eeprom").string();
  for (const std::string bad : {"10.1.2", "localhost", "010.1.1.1", "1.2.3.4.5", "::1", "127.0.0.1 :0"}) {
    auto r = test_support::run({"sim", "--bind", bad, "--api", "0", "--no-realtime", "--state", state},
                               std::chrono::seconds(10));
    EXPECT_EQ(r.exit, 1) << bad << "\n" << r.out << r.err;
    EXPECT_NE(r.err.find("--bind \"" + bad + "\""), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("is not an IPv4 address"), std::string::npos) << r.err;
    r = test_support::run({"sim", "--bind", loopback(44) + ":0", "--bind", bad, "--api", "0", "--no-realtime", "--state",
                           folder.path().string()},
                          std::chrono::seconds(10));
    EXPECT_EQ(r.exit, 1) << bad << "\n" << r.out << r.err;
    EXPECT_NE(r.err.find("--bind \"" + bad + "\""), std::string::npos) << r.err;
    EXPECT_TRUE(filesIn(folder.path()).empty()) << bad;
  }
}

// A bind that fails (the port taken by another program) takes back every
// file the start wrote, with one card and with several, and leaves the
// files that were there as they were.
TEST(SimApi, ABindThatFailsLeavesNoStateFileBehind) {
  test_support::TempDir folder("lbpkit-cards");
  const std::string a = loopback(45), b = loopback(46);
  const int taken = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  ASSERT_GE(taken, 0);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  ASSERT_EQ(::inet_pton(AF_INET, b.c_str(), &sa.sin_addr), 1);
  ASSERT_EQ(::bind(taken, reinterpret_cast<sockaddr*>(&sa), sizeof sa), 0);
  socklen_t length = sizeof sa;
  ASSERT_EQ(::getsockname(taken, reinterpret_cast<sockaddr*>(&sa), &length), 0);
  const std::string busy = b + ":" + std::to_string(ntohs(sa.sin_port));
  // Card a's EEPROM from an earlier run: kept, byte for byte.
  const auto kept = folder.path() / ("7i77-" + a + "-0.eeprom");
  ASSERT_EQ(test_support::run({"wpd", "NVWATCHDOGTIME", "60", "--state", kept.string()}).exit, 0);
  const auto before = filesIn(folder.path());
  ASSERT_FALSE(before.empty());

  auto r = test_support::run({"sim", "--bind", a + ":0", "--bind", busy, "--api", "0", "--no-realtime", "--state",
                              folder.path().string()},
                             std::chrono::seconds(10));
  EXPECT_EQ(r.exit, 1) << r.out << r.err;
  EXPECT_NE(r.err.find("cannot listen on " + busy), std::string::npos) << r.err;
  EXPECT_EQ(filesIn(folder.path()), before);

  r = test_support::run({"sim", "--bind", busy, "--api", "0", "--no-realtime", "--state",
                         (folder.path() / "one").string()},
                        std::chrono::seconds(10));
  EXPECT_EQ(r.exit, 1) << r.out << r.err;
  EXPECT_EQ(filesIn(folder.path()), before);
  ::close(taken);
}

// A --state folder (several cards) or a --state file's folder (one card)
// that does not exist is refused alike, naming it, and not created.
TEST(SimApi, AMissingStateFolderIsRefusedWithOneCardAndWithSeveral) {
  test_support::TempDir folder("lbpkit-cards");
  const auto missing = (folder.path() / "missing").string();
  const std::string a = loopback(47), b = loopback(48);
  auto r = test_support::run(
      {"sim", "--bind", a + ":0", "--bind", b + ":0", "--api", "0", "--no-realtime", "--state", missing},
      std::chrono::seconds(10));
  EXPECT_EQ(r.exit, 1) << r.out << r.err;
  EXPECT_NE(r.err.find("the directory " + missing + " does not exist"), std::string::npos) << r.err;
  r = test_support::run({"sim", "--bind", a + ":0", "--api", "0", "--no-realtime", "--state", missing + "/eeprom"},
                        std::chrono::seconds(10));
  EXPECT_EQ(r.exit, 1) << r.out << r.err;
  EXPECT_NE(r.err.find("the directory " + missing + " does not exist"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(missing));
}

// --- The card thread never locks up -------------------------------------

// Latches a counter's count on its index (CCR bit 4), as LinuxCNC does for
// index-enable, through LBP16.
void latchOnIndex(const Sim& sim, unsigned counters) {
  Bytes d;
  for (unsigned n = 0; n < counters; ++n) {
    command(d, {true, true, false, 0, 4, true, 1}, static_cast<std::uint16_t>(hm2::MuxedEncoder::kControl + 4 * n));
    put32(d, hm2::MuxedEncoder::kLatchOnIndex);
  }
  cookieRead(d);
  ASSERT_EQ(exchange(sim.address(), sim.udpPort(), d).size(), 4U);
}

// Time at 1000x and six encoders at 2 MHz with an index every count: the
// card thread stopped answering, refused API changes and ignored SIGTERM.
TEST(SimApi, TheCardThreadKeepsAnsweringAtSpeed1000WithAnIndexEveryCount) {
  Sim sim(loopback(6));
  ASSERT_TRUE(sim.up());
  latchOnIndex(sim, 6);
  for (int n = 0; n < 6; ++n)
    ASSERT_EQ(sim.post("/api/encoder", {{"encoder", n}, {"velocity", 2e6}, {"counts_per_rev", 1}}).status, 200);
  // The card thread keeps answering: each request is answered, however long
  // a busy or sanitized machine takes (printed; the card thread's budget per
  // catch-up bounds it, SimClock::kBudget).
  ASSERT_EQ(sim.post("/api/time", {{"speed", 1000}}, 30000ms).status, 200);
  std::this_thread::sleep_for(500ms);
  double last = -1;
  for (int round = 0; round < 3; ++round) {
    const auto r = sim.get("/api/state", 30000ms);
    ASSERT_EQ(r.status, 200) << r.raw.substr(0, 200);
    std::printf("GET /api/state at speed 1000, an index every count on six encoders: answered in %lld ms\n",
                static_cast<long long>(r.took.count()));
    const double t = r.body["time_s"].get<double>();
    EXPECT_GT(t, last);
    last = t;
    ASSERT_TRUE(r.body["clock"].contains("behind_ms")) << r.body["clock"];
    ASSERT_TRUE(r.body["clock"].contains("slips")) << r.body["clock"];
    EXPECT_TRUE(r.body["daughtercards"][0]["encoders"][0]["position"].is_number());
    std::this_thread::sleep_for(200ms);
  }
  // Changes still go through.
  EXPECT_EQ(sim.post("/api/field", {{"volts", 20.0}}, 30000ms).status, 200);
  EXPECT_EQ(sim.stopWithin(5000ms), 0);
}

// When the card cannot keep up (encoders too fast for the filter are
// simulated sample by sample), simulated time falls behind the wall clock,
// visibly, instead of the card thread falling behind forever.
TEST(SimApi, WhenTheCardCannotKeepUpSimulatedTimeFallsBehindVisibly) {
  // A load the card thread cannot carry at 10000x: the mill with its axes
  // moving (pushed slowly, for longer than the test lasts), its plant
  // solved every simulated millisecond, runs some thousands of times real
  // time on one core (benchmarks/machine_benchmark.cpp, BM_MillPlantOnly).
  // An idle machine is not one (it rests: Machine::resting), nor are fast
  // encoders alone: unread counters cost nothing (they settle when looked at).
  Sim sim(loopback(7), {"--machine", "mill"});
  ASSERT_TRUE(sim.up());
  for (const char* axis : {"x", "y", "z"})
    ASSERT_EQ(sim.post("/api/machine", {{"action", "push"}, {"axis", axis}, {"distance", -100.0}, {"speed", 0.005}}).status,
              200);
  ASSERT_EQ(sim.post("/api/time", {{"speed", 10000}}).status, 200);
  std::this_thread::sleep_for(1000ms);
  const auto r = sim.get("/api/state", 2000ms);
  ASSERT_EQ(r.status, 200);
  EXPECT_LT(r.took.count(), 1000);
  EXPECT_GT(r.body["clock"]["slips"].get<double>(), 0) << r.body["clock"];
  EXPECT_GT(r.body["clock"]["behind_ms"].get<double>(), 0) << r.body["clock"];
  EXPECT_LT(r.body["time_s"].get<double>(), 10000 * 1.5);
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

// --- Who may use the API -----------------------------------------------

// A web page in the user's browser could POST (text/plain, no preflight) and
// unplug a channel; a DNS-rebinding page could read and write as if local.
TEST(SimApi, RefusesForeignOriginsHostsAndNonJsonPosts) {
  Sim sim(loopback(8));
  ASSERT_TRUE(sim.up());
  const auto own = sim.address() + ":" + std::to_string(sim.apiPort());
  Request unplug;
  unplug.method = "POST";
  unplug.path = "/api/cable";
  unplug.body = R"({"channel": 0, "connected": false})";
  auto q = unplug;
  q.headers = {"Origin: http://evil.example"};
  q.contentType = "text/plain";
  auto r = sim.send(q);
  EXPECT_EQ(r.status, 403) << r.raw;
  EXPECT_TRUE(r.body.contains("error")) << r.raw;
  q.contentType = "application/json";
  EXPECT_EQ(sim.send(q).status, 403);
  q = unplug;
  q.host = "evil.example:" + std::to_string(sim.apiPort());  // DNS rebinding
  r = sim.send(q);
  EXPECT_EQ(r.status, 403) << r.raw;
  EXPECT_NE(r.body.value("error", "").find("Host"), std::string::npos) << r.raw;
  Request get;
  get.host = "evil.example";
  EXPECT_EQ(sim.send(get).status, 403);
  // A second Host or Origin after the good one: none is taken.
  q = unplug;
  q.headers = {"Host: evil.example"};
  r = sim.send(q);
  EXPECT_EQ(r.status, 400) << r.raw;
  EXPECT_NE(r.body.value("error", "").find("Host is given more than once"), std::string::npos) << r.raw;
  q.headers = {"Origin: http://" + own, "Origin: http://evil.example"};
  EXPECT_EQ(sim.send(q).status, 400);
  q = unplug;
  q.contentType = "text/plain";
  r = sim.send(q);
  EXPECT_EQ(r.status, 415) << r.raw;
  EXPECT_NE(r.body.value("error", "").find("application/json"), std::string::npos) << r.raw;
  q.contentType = "application/x-www-form-urlencoded";  // what curl -d sends
  EXPECT_EQ(sim.send(q).status, 415);
  q.contentType = "";
  EXPECT_EQ(sim.send(q).status, 415);
  // Nothing got through.
  r = sim.get();
  ASSERT_EQ(r.status, 200);
  EXPECT_TRUE(r.body["sserial"]["channels"][0]["cable_connected"].get<bool>());
  // Its own origin, localhost, and a JSON content type with parameters pass.
  q = unplug;
  q.headers = {"Origin: http://" + own};
  q.contentType = "application/json; charset=utf-8";
  EXPECT_EQ(sim.send(q).status, 200);
  get.host = "localhost:" + std::to_string(sim.apiPort());
  EXPECT_EQ(sim.send(get).status, 200);
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

TEST(SimApi, ATokenIsRequiredWhenSet) {
  for (const bool fromEnvironment : {false, true}) {
    if (fromEnvironment) ::setenv("LBPKIT_API_TOKEN", "s3cret-from-env", 1);
    const std::string token = fromEnvironment ? "s3cret-from-env" : "s3cret";
    Sim sim(loopback(9), fromEnvironment ? std::vector<std::string>{} : std::vector<std::string>{"--api-token", token});
    ::unsetenv("LBPKIT_API_TOKEN");
    ASSERT_TRUE(sim.up());
    auto r = sim.get();
    EXPECT_EQ(r.status, 401) << r.raw;
    EXPECT_TRUE(r.body.contains("error")) << r.raw;
    Request q;
    q.headers = {"Authorization: Bearer wrong"};
    EXPECT_EQ(sim.send(q).status, 401);
    q.headers = {"Authorization: Bearer " + token};
    EXPECT_EQ(sim.send(q).status, 200);
    q.method = "POST";
    q.path = "/api/field";
    q.body = R"({"volts": 12})";
    EXPECT_EQ(sim.send(q).status, 200);
    q.headers = {};
    EXPECT_EQ(sim.send(q).status, 401);
    EXPECT_EQ(sim.stopWithin(2000ms), 0);
  }
}

// `--bind 0.0.0.0` and `--api 0.0.0.0` started without a word, and the
// banner advised board_ip=0.0.0.0.
TEST(SimApi, WarnsWhenServingBeyondLoopback) {
  const auto state = tempPath("anywhere");
  const auto r = test_support::run(
      {"sim", "--bind", "0.0.0.0:0", "--api", "0.0.0.0:0", "--no-realtime", "--state", state}, std::chrono::seconds(5));
  EXPECT_NE(r.err.find("warning: the control API on 0.0.0.0"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("--api-token"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("warning: LBP16 on 0.0.0.0"), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("board_ip="), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("board_ip=0.0.0.0"), std::string::npos) << r.out;
  // run() kills the sim at its limit, so it leaves its owner notes too.
  test_support::removeStateFiles(state);
}

// --- Values with no physical meaning ----------------------------------

TEST(SimApi, RefusesValuesWithNoPhysicalMeaning) {
  Sim sim(loopback(10));
  ASSERT_TRUE(sim.up());
  struct Case {
    const char* path;
    json body;
    const char* says;  // the key and its range
  };
  const Case cases[] = {
      {"/api/field", {{"volts", 1e308}}, "\"volts\" must be a number from 0 to 36"},
      {"/api/field", {{"volts", -1}}, "\"volts\" must be a number from 0 to 36"},
      {"/api/field", {{"vin", 40}}, "\"vin\" must be a number from 0 to 36"},
      {"/api/input", {{"input", 3}, {"volts", -1e308}}, "\"volts\" must be a number from 0 to 36"},
      {"/api/input", {{"input", 3}, {"volts", "high"}}, "\"volts\" must be a number from 0 to 36"},
      {"/api/output", {{"output", 3}, {"ohms", -5}}, "\"ohms\" must be a number above 0"},
      {"/api/output", {{"output", 3}, {"ohms", 0}}, "\"ohms\" must be a number above 0"},
      {"/api/encoder", {{"encoder", 1}, {"velocity", 1e308}}, "\"velocity\" must be a number from -1e+07 to 1e+07"},
      {"/api/encoder", {{"encoder", 1}, {"counts_per_rev", 4294967295U}}, "\"counts_per_rev\" must be a whole number from 0 to 2147483648"},
      {"/api/encoder", {{"encoder", 1}, {"counts_per_rev", -1}}, "\"counts_per_rev\" must be a whole number from 0 to 2147483648"},
      {"/api/time", {{"speed", 1e308}}, "\"speed\" must be a number above 0 and at most 10000"},
      {"/api/time", {{"speed", 0}}, "\"speed\" must be a number above 0 and at most 10000"},
      {"/api/time", {{"step_ms", 1e9}}, "\"step_ms\" must be a number from 0 to 60000"},
      {"/api/time", {{"paused", "yes"}}, "\"paused\" must be true or false"},
      // A misspelt key is refused, as everywhere in the API, not ignored.
      {"/api/input", {{"input", 3}, {"vots", 3}}, "unknown key \"vots\""},
      {"/api/field", {{"volt", 24}}, "unknown key \"volt\""},
      {"/api/output", {{"output", 3}, {"ohm", 80}}, "unknown key \"ohm\""},
      {"/api/encoder", {{"encoder", 1}, {"velocty", 5}}, "unknown key \"velocty\""},
      {"/api/cable", {{"channel", 1}, {"conected", false}}, "unknown key \"conected\""},
      {"/api/time", {{"pause", true}}, "unknown key \"pause\""},
  };
  for (const auto& c : cases) {
    const auto r = sim.post(c.path, c.body);
    EXPECT_EQ(r.status, 400) << c.path << " " << c.body;
    EXPECT_NE(r.body.value("error", "").find(c.says), std::string::npos) << c.path << " " << c.body << ": " << r.raw;
  }
  // Open (null) and real loads, and the limits themselves, are fine.
  EXPECT_EQ(sim.post("/api/output", {{"output", 3}, {"ohms", nullptr}}).status, 200);
  EXPECT_EQ(sim.post("/api/output", {{"output", 3}, {"ohms", 80}}).status, 200);
  EXPECT_EQ(sim.post("/api/field", {{"volts", 36}}).status, 200);
  EXPECT_EQ(sim.post("/api/encoder", {{"encoder", 1}, {"velocity", -1e7}, {"counts_per_rev", 2147483648U}}).status, 200);
  const auto r = sim.get();
  ASSERT_EQ(r.status, 200);
  EXPECT_TRUE(r.body["daughtercards"][0]["encoders"][1]["position"].is_number());
  EXPECT_GE(r.body["time_s"].get<double>(), 0);
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

TEST(SimApi, CliRefusesSpeedsWithNoPhysicalMeaning) {
  for (const char* speed : {"1e308", "inf", "nan", "0", "-1", "10001"}) {
    const auto state = tempPath("speed");
    const auto r = test_support::run(
        {"sim", "--bind", loopback(11) + ":0", "--api", "0", "--no-realtime", "--state", state, "--speed", speed},
        std::chrono::seconds(5));
    EXPECT_NE(r.exit, 0) << speed;
    EXPECT_NE(r.err.find("--speed"), std::string::npos) << speed << ": " << r.err;
    EXPECT_NE(r.err.find("10000"), std::string::npos) << speed << ": " << r.err;
    test_support::removeStateFiles(state);
  }
}

// lbpkit's host library on a sim's card over UDP, both 7I77 channels
// discovered and in normal mode. What the tests look at is the card, not
// the reply time: on loopback a reply is never lost, only late (this runs
// beside other tests, and under ASan), so each cycle waits up to 500 ms.
struct HostOnSim {
  explicit HostOnSim(Sim& sim)
      : t(sim.address(), static_cast<std::uint16_t>(sim.udpPort())), info(slowCardInfo(t)), ss(t, info, channels()) {
    ss.discover(0x03);
    ss.startNormal();
  }
  static lbpkit::CardInfo slowCardInfo(lbpkit::Lbp16Transport& transport) {
    transport.setCycleTimeout(500ms);
    return lbpkit::readCardInfo(transport);
  }
  static lbpkit::SmartSerial::Options channels() {
    lbpkit::SmartSerial::Options o;
    o.channelMask = 0x03;
    return o;
  }
  lbpkit::Lbp16Transport t;
  lbpkit::CardInfo info;
  lbpkit::SmartSerial ss;
};

// `--clock`: what it takes, and what it refuses, naming the option.
TEST(SimApi, CliRefusesClocksItDoesNotKnow) {
  for (const auto& extra :
       {std::vector<std::string>{"--clock", "sun"}, {"--clock", "host=50us"}, {"--clock", "host=11ms"},
        {"--clock", "host=1s"}, {"--clock", "host=ms"}, {"--clock", "host=1ms", "--speed", "2"}}) {
    const auto state = tempPath("clock");
    std::vector<std::string> args = {"sim", "--bind", loopback(11) + ":0", "--api", "0", "--no-realtime", "--state",
                                     state};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto r = test_support::run(args, std::chrono::seconds(5));
    EXPECT_NE(r.exit, 0) << extra[1];
    EXPECT_NE(r.err.find("--clock"), std::string::npos) << extra[1] << ": " << r.err;
    test_support::removeStateFiles(state);
  }
}

// On the host clock, lbpkit's own host library drives time: each of its
// cycles (a DoIt) moves the card one period, however the cycles are spaced
// on the wall clock; the API shows the clock and refuses a speed. The
// period in nanoseconds, as [EMCMOT]SERVO_PERIOD gives it and `lbpkit
// linuxcnc` passes it on.
TEST(SimApi, OnTheHostClockEachHostCycleIsOnePeriod) {
  Sim sim(loopback(18), {"--clock", "host=1000000"});
  ASSERT_TRUE(sim.up());
  EXPECT_NE(sim.daemon().readUntil("per host cycle").find("one servo period (1 ms) per host cycle"), std::string::npos);
  HostOnSim host(sim);
  auto& t = host.t;
  auto& ss = host.ss;
  ASSERT_TRUE(ss.cycle().ok);
  const json before = sim.get().body;
  ASSERT_EQ(before["clock"]["source"], "host") << before["clock"];
  EXPECT_EQ(before["clock"]["period_ms"], 1.0);
  constexpr int kCycles = 300;
  for (int i = 0; i < kCycles; ++i) {
    ASSERT_TRUE(ss.cycle().ok) << i;
    if (i % 50 == 0) t.sleep(4ms);  // a late period: still one period
  }
  const json after = sim.get().body;
  EXPECT_EQ(after["clock"]["host_cycles"].get<std::uint64_t>() - before["clock"]["host_cycles"].get<std::uint64_t>(),
            static_cast<std::uint64_t>(kCycles));
  // A period a cycle, exactly; a cycle that came over 40 ms after the last
  // (this test's process held back on a busy machine: the sim cannot tell
  // that from a host that stopped) adds the wall-clock time it was silent.
  const auto silences =
      after["clock"]["host_silences"].get<std::uint64_t>() - before["clock"]["host_silences"].get<std::uint64_t>();
  // A look at the clock over 40 ms after the last cycle reads it moved on
  // with the wall clock too: exact only when both looks found the host
  // driving it.
  const double elapsed = after["time_s"].get<double>() - before["time_s"].get<double>();
  const bool driven = before["clock"]["driven_by_host"] == true && after["clock"]["driven_by_host"] == true;
  if (silences == 0 && driven)
    EXPECT_NEAR(elapsed, kCycles * 1e-3, 1e-9);
  else
    EXPECT_GT(elapsed, kCycles * 1e-3) << silences << " silences";
  const auto speed = sim.post("/api/time", {{"speed", 2}});
  EXPECT_EQ(speed.status, 400);
  EXPECT_NE(speed.body.value("error", "").find("host"), std::string::npos) << speed.body;
  // A silent host: time follows the wall clock again, and the 7I77's
  // watchdog bites (its outputs off) as on the wall clock.
  std::this_thread::sleep_for(120ms);
  const json silent = sim.get().body;
  EXPECT_EQ(silent["clock"]["driven_by_host"], false);
  EXPECT_GT(silent["time_s"].get<double>() - after["time_s"].get<double>(), 0.1);
  const auto& faults = silent["daughtercards"][0]["field_io"]["faults"];
  EXPECT_NE(std::find(faults.begin(), faults.end(), "WatchdogFault"), faults.end()) << silent["daughtercards"][0];
}

// hm2_eth's set-up writes a STOP ALL after its discovery DoIts and gives it
// 51 ms of the wall clock (LinuxCNC: hostmot2/sserial.c). A command that is
// no DoIt takes the host out of its cycle: the card follows the wall clock
// at once (the STOP done in its firmware time, not after the host's 40 ms
// silence), and the next cycle drives time again.
TEST(SimApi, OnTheHostClockACommandOutOfTheCycleMeetsTheWallClock) {
  Sim sim(loopback(18), {"--clock", "host=1ms"});
  ASSERT_TRUE(sim.up());
  HostOnSim host(sim);
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(host.ss.cycle().ok) << i;
  const json cycling = sim.get().body;
  // stopAll() writes STOP ALL and reads COMMAND until it clears.
  EXPECT_EQ(host.ss.stopAll(), 0xAA) << "DATA after the global init";
  const json stopped = sim.get().body;
  EXPECT_EQ(stopped["clock"]["driven_by_host"], false) << stopped["clock"];
  EXPECT_EQ(stopped["clock"]["host_left_cycle"].get<std::uint64_t>(),
            cycling["clock"]["host_left_cycle"].get<std::uint64_t>() + 1)
      << stopped["clock"];
  EXPECT_EQ(stopped["clock"]["host_silences"], cycling["clock"]["host_silences"]) << "no silence counted";
  EXPECT_GE(stopped["clock"]["host_cycles"].get<std::uint64_t>(), 20U);
}

// --- What /api/state shows ---------------------------------------------

// mesaflash writes the card's EEPROM IP (with the write enable) to move a
// card to another address: /api/state showed none of it.
TEST(SimApi, TheEepromWrittenThroughLbp16ShowsInState) {
  Sim sim(loopback(12));
  ASSERT_TRUE(sim.up());
  auto r = sim.get();
  ASSERT_EQ(r.status, 200);
  ASSERT_TRUE(r.body["card"].contains("eeprom")) << r.body["card"];
  EXPECT_EQ(r.body["card"]["eeprom"]["ip"], sim.address());
  EXPECT_EQ(r.body["card"]["eeprom"]["name"], "7I92");
  EXPECT_EQ(r.body["card"]["eeprom"]["mac"], r.body["card"]["mac"]);
  Bytes d;
  command(d, {true, true, false, 6, 2, true, 1}, lbp16::comm::kEepromWriteEnable);
  put16(d, lbp16::kEepromWriteEnableKey);
  command(d, {true, true, false, 2, 2, true, 2}, lbp16::eeprom::kIp);
  put16(d, (1 << 8) | 121);    // c.d
  put16(d, (192 << 8) | 168);  // a.b
  command(d, {true, true, false, 2, 2, true, 1}, lbp16::eeprom::kMac);
  put16(d, (0x56 << 8) | 0x78);  // the last two bytes of the MAC: read only (Mesa's LBPPARSE.ASM)
  cookieRead(d);
  ASSERT_EQ(exchange(sim.address(), sim.udpPort(), d).size(), 4U);
  r = sim.get();
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(r.body["card"]["eeprom"]["ip"], "192.168.1.121") << r.body["card"];
  EXPECT_EQ(r.body["card"]["eeprom"]["mac"], r.body["card"]["mac"]) << "the MAC cannot be written";
  EXPECT_EQ(r.body["lbp16"]["write_errors"], 1);
  // Without the enable nothing changes.
  Bytes w;
  command(w, {true, true, false, 2, 2, true, 1}, lbp16::eeprom::kIp);
  put16(w, 0);
  cookieRead(w);
  ASSERT_EQ(exchange(sim.address(), sim.udpPort(), w).size(), 4U);
  EXPECT_EQ(sim.get().body["card"]["eeprom"]["ip"], "192.168.1.121");
  // The server's figures include the time a datagram queued in the socket.
  const auto server = sim.get().body["server"];
  EXPECT_TRUE(server.contains("queue_p99_us")) << server;
  EXPECT_TRUE(server.contains("queue_max_us")) << server;
  EXPECT_GE(server["max_us"].get<double>(), server["queue_max_us"].get<double>()) << server;
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

// --- The machine behind the 7I77 ---------------------------------------

json axisNamed(const json& machine, const std::string& name) {
  for (const auto& a : machine["axes"])
    if (a["name"] == name) return a;
  return {};
}

// Polls GET /api/machine until `done` says so (5 s at most); the last answer.
template <typename Done>
json machineWhen(Sim& sim, Done done) {
  json m;
  const auto end = Clock::now() + 5s;
  do {
    m = sim.get("/api/machine").body;
    if (done(m)) break;
    std::this_thread::sleep_for(20ms);
  } while (Clock::now() < end);
  return m;
}

TEST(SimMachine, WithoutAMachineTheMachineRoutesAnswer404) {
  Sim sim(loopback(13));
  ASSERT_TRUE(sim.up());
  for (const auto* path : {"/api/machine", "/api/machine/trace"}) {
    const auto r = sim.get(path);
    EXPECT_EQ(r.status, 404) << path;
    EXPECT_NE(r.body.value("error", "").find("--machine"), std::string::npos) << r.raw;
  }
  EXPECT_EQ(sim.post("/api/machine", {{"action", "estop"}, {"pressed", true}}).status, 404);
  const auto r = sim.get();
  ASSERT_EQ(r.status, 200);
  ASSERT_TRUE(r.body.contains("machine"));
  EXPECT_TRUE(r.body["machine"].is_null());
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

TEST(SimMachine, GetMachineShowsTheMillAndItsActionsWork) {
  Sim sim(loopback(14), {"--machine", "mill"});
  ASSERT_TRUE(sim.up());
  EXPECT_NE(sim.daemon().readUntil("machine: mill").find("machine: mill (built-in mill)"), std::string::npos);
  auto r = sim.get("/api/machine");
  ASSERT_EQ(r.status, 200) << r.raw;
  auto m = r.body;
  EXPECT_EQ(m["name"], "mill");
  ASSERT_EQ(m["axes"].size(), 3U);
  EXPECT_EQ(m["axes"][0]["name"], "x");
  EXPECT_EQ(m["axes"][0]["position"].get<double>(), 200.0);
  EXPECT_EQ(m["axes"][1]["position"].get<double>(), 150.0);
  EXPECT_EQ(m["axes"][2]["position"].get<double>(), -75.0);
  const auto& drive = m["axes"][0]["drives"][0];
  for (const auto* key : {"analog_output", "command_volts", "ena", "enabled", "torque", "encoder_input", "encoder_count",
                          "true_counts", "encoder_broken"})
    EXPECT_TRUE(drive.contains(key)) << key;
  EXPECT_EQ(m["axes"][0]["switches"].size(), 3U);
  EXPECT_EQ(m["axes"][0]["switches"][2]["name"], "x-max");
  EXPECT_EQ(m["axes"][0]["switches"][2]["kind"], "max_limit");
  EXPECT_TRUE(m["axes"][0]["switches"][2]["input_on"].get<bool>());  // normally closed, inside the travel
  EXPECT_TRUE(m["estop_ok"].get<bool>());
  EXPECT_FALSE(m["probe"].get<bool>());
  EXPECT_EQ(m["switches"].size(), 11U);
  EXPECT_EQ(m["outputs"][0]["name"], "coolant");
  EXPECT_TRUE(m["spindle"].is_object());
  // The same in /api/state.
  r = sim.get();
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(r.body["machine"]["name"], "mill");

  // E-stop: the chain's input (9) goes off, in the machine and at the 7I77.
  r = sim.post("/api/machine", {{"action", "estop"}, {"pressed", true}});
  ASSERT_EQ(r.status, 200) << r.raw;
  EXPECT_FALSE(r.body["estop_ok"].get<bool>());
  r = sim.get();
  EXPECT_FALSE(r.body["daughtercards"][0]["field_io"]["inputs"][9]["on"].get<bool>());
  r = sim.post("/api/machine", {{"action", "estop"}, {"pressed", false}});
  EXPECT_TRUE(r.body["estop_ok"].get<bool>());
  r = sim.post("/api/machine", {{"action", "probe"}, {"touching", true}});
  EXPECT_TRUE(r.body["probe"].get<bool>());
  r = sim.post("/api/machine", {{"action", "switch"}, {"name", "y-min"}, {"tripped", true}});
  ASSERT_EQ(r.status, 200);
  EXPECT_TRUE(axisNamed(r.body, "y")["switches"][1]["tripped"].get<bool>());
  EXPECT_FALSE(axisNamed(r.body, "y")["switches"][1]["input_on"].get<bool>());

  // A push moves Y by 3 mm (the drives are off: nothing pushes back).
  r = sim.post("/api/machine", {{"action", "push"}, {"axis", "y"}, {"distance", 3.0}, {"speed", 100.0}});
  ASSERT_EQ(r.status, 200) << r.raw;
  m = machineWhen(sim, [](const json& j) { return !axisNamed(j, "y")["pushing"].get<bool>(); });
  EXPECT_NEAR(axisNamed(m, "y")["position"].get<double>(), 153.0, 1e-6);
  EXPECT_NEAR(axisNamed(m, "y")["drives"][0]["true_counts"].get<double>(), 153.0 * 1600.0, 1e-3);
  // Jammed, a push waits.
  r = sim.post("/api/machine", {{"action", "jam"}, {"axis", "x"}, {"jammed", true}});
  EXPECT_TRUE(axisNamed(r.body, "x")["jammed"].get<bool>());
  r = sim.post("/api/machine", {{"action", "push"}, {"axis", "x"}, {"distance", -1.0}});
  EXPECT_TRUE(axisNamed(r.body, "x")["pushing"].get<bool>());
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(axisNamed(sim.get("/api/machine").body, "x")["position"].get<double>(), 200.0);
  sim.post("/api/machine", {{"action", "jam"}, {"axis", "x"}, {"jammed", false}});
  m = machineWhen(sim, [](const json& j) { return !axisNamed(j, "x")["pushing"].get<bool>(); });
  EXPECT_NEAR(axisNamed(m, "x")["position"].get<double>(), 199.0, 1e-6);
  // Encoder channels, the spindle's too.
  r = sim.post("/api/machine", {{"action", "encoder"}, {"axis", "z"}, {"channel", "A"}, {"broken", true}});
  ASSERT_EQ(r.status, 200);
  EXPECT_EQ(axisNamed(r.body, "z")["drives"][0]["encoder_broken"], json::array({"A"}));
  r = sim.post("/api/machine", {{"action", "encoder"}, {"axis", "spindle"}, {"channel", "index"}, {"broken", true}});
  ASSERT_EQ(r.status, 200) << r.raw;
  EXPECT_EQ(r.body["spindle"]["encoder_broken"], json::array({"index"}));
  r = sim.get();
  EXPECT_EQ(r.body["daughtercards"][0]["encoders"][5]["counts_per_rev"].get<int>(), 0);  // no index pulses
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

TEST(SimMachine, BadMachineActionsAreRefusedNamingTheField) {
  Sim sim(loopback(15), {"--machine", "lathe"});
  ASSERT_TRUE(sim.up());
  struct Case {
    json body;
    const char* says;
  };
  const std::vector<Case> cases = {
      {json::object(), "missing \"action\""},
      {{{"action", 3}}, "\"action\" must be a string"},
      {{{"action", "fly"}}, "\"action\" must be one of push, jam, encoder, estop, probe, switch"},
      {{{"action", "push"}, {"distance", 1.0}}, "missing \"axis\""},
      {{{"action", "push"}, {"axis", "y"}, {"distance", 1.0}}, "this machine has no axis \"y\" (it has x, z)"},
      {{{"action", "push"}, {"axis", "x"}}, "missing \"distance\""},
      {{{"action", "push"}, {"axis", "x"}, {"distance", "far"}}, "\"distance\" must be a number"},
      {{{"action", "push"}, {"axis", "x"}, {"distance", 1e9}}, "\"distance\" must be a number"},
      {{{"action", "push"}, {"axis", "x"}, {"distance", 1.0}, {"speed", 0}}, "\"speed\" must be a number above 0"},
      {{{"action", "push"}, {"axis", "x"}, {"distance", 1.0}, {"speed", -5}}, "\"speed\" must be a number above 0"},
      {{{"action", "jam"}, {"axis", "x"}}, "missing \"jammed\""},
      {{{"action", "jam"}, {"axis", "x"}, {"jammed", 1}}, "\"jammed\" must be true or false"},
      {{{"action", "encoder"}, {"axis", "q"}, {"channel", "A"}, {"broken", true}}, "no axis \"q\""},
      {{{"action", "encoder"}, {"axis", "x"}, {"channel", "Z"}, {"broken", true}},
       "\"channel\" must be \"A\", \"B\" or \"index\""},
      {{{"action", "encoder"}, {"axis", "x"}, {"drive", 1}, {"channel", "A"}, {"broken", true}},
       "\"drive\" must be a whole number below 1"},
      {{{"action", "encoder"}, {"axis", "x"}, {"channel", "A"}}, "missing \"broken\""},
      {{{"action", "estop"}}, "missing \"pressed\""},
      {{{"action", "probe"}, {"touching", "yes"}}, "\"touching\" must be true or false"},
      {{{"action", "switch"}, {"name", "nope"}, {"tripped", true}}, "this machine has no switch \"nope\""},
      {{{"action", "switch"}, {"tripped", true}}, "missing \"name\""},
      {{{"action", "push"}, {"axis", "x"}, {"distance", 1.0}, {"sped", 2}}, "unknown key \"sped\""},
      {{{"action", "estop"}, {"pressed", true}, {"axis", "x"}}, "unknown key \"axis\""},
  };
  for (const auto& c : cases) {
    const auto r = sim.post("/api/machine", c.body);
    EXPECT_EQ(r.status, 400) << c.body.dump() << " " << r.raw;
    EXPECT_NE(r.body.value("error", "").find(c.says), std::string::npos) << c.body.dump() << " " << r.raw;
  }
  for (const auto* q : {"since=x", "since=", "since=1e400", "since=5s"}) {
    const auto r = sim.get(std::string("/api/machine/trace?") + q);
    EXPECT_EQ(r.status, 400) << q << " " << r.raw;
    EXPECT_NE(r.body.value("error", "").find("\"since\" must be a number"), std::string::npos) << r.raw;
  }
  // Nothing changed.
  const auto m = sim.get("/api/machine").body;
  EXPECT_EQ(axisNamed(m, "x")["position"].get<double>(), 50.0);
  EXPECT_FALSE(axisNamed(m, "x")["jammed"].get<bool>());
  EXPECT_TRUE(m["estop_ok"].get<bool>());
  EXPECT_EQ(sim.stopWithin(2000ms), 0);
}

TEST(SimMachine, TheCliRefusesMachineMistakes) {
  const auto state = tempPath("machine-cli");
  auto r = test_support::run({"sim", "--machine", "mill", "--demo", "--no-realtime", "--state", state},
                                std::chrono::seconds(5));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE((r.out + r.err).find("--demo"), std::string::npos) << r.out << r.err;
  r = test_support::run({"sim", "--record", tempPath("orphan.csv"), "--no-realtime", "--state", state},
                           std::chrono::seconds(5));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("--record needs --machine"), std::string::npos) << r.err;
  r = test_support::run({"sim", "--machine", tempPath("no-such-machine.toml"), "--no-realtime", "--state", state},
                           std::chrono::seconds(5));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("no-such-machine.toml"), std::string::npos) << r.err;
  r = test_support::run({"sim", "--machine", "mill", "--record", "/nonexistent-dir/trace.csv", "--bind",
                            loopback(16) + ":0", "--api", loopback(16) + ":0", "--no-realtime", "--state", state},
                           std::chrono::seconds(5));
  EXPECT_NE(r.exit, 0);
  EXPECT_NE(r.err.find("--record /nonexistent-dir/trace.csv: No such file or directory"), std::string::npos) << r.err;
  test_support::removeStateFiles(state);
}

// --trace and --record write only what the user named as output: never
// through a link, never a FIFO, never the sim's own EEPROM, and an existing
// file only when it is the output of an earlier run.
TEST(SimOutputFiles, TraceAndRecordNeverWriteOverWhatTheUserDidNotName) {
  namespace fs = std::filesystem;
  auto slurp = [](const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  const auto state = tempPath("outputs.eeprom");
  {
    Sim first(test_support::SimOptions{loopback(19), 0, {}, true, state, {}});
    ASSERT_TRUE(first.up());
    EXPECT_EQ(first.stop(), 0);
  }
  const auto eeprom = slurp(state);
  ASSERT_FALSE(eeprom.empty());
  auto refused = [&](const std::vector<std::string>& extra, const std::string& why) {
    std::vector<std::string> args{"sim", "--bind", loopback(19) + ":0", "--api", loopback(19) + ":0", "--no-realtime",
                                  "--state", state};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto r = test_support::run(args, std::chrono::seconds(10));
    EXPECT_NE(r.exit, 0) << r.out << r.err;
    EXPECT_NE(r.err.find(why), std::string::npos) << r.out << r.err;
  };
  // The sim's own EEPROM, by its own path and through another name for it.
  refused({"--trace", state}, "is the sim's own");
  const auto hard = tempPath("hard.pcap");
  fs::create_hard_link(state, hard);
  refused({"--trace", hard}, "is the sim's own");
  EXPECT_EQ(slurp(state), eeprom) << "the EEPROM is untouched";
  // A link, and what it points at untouched.
  const auto precious = tempPath("precious.txt");
  std::ofstream(precious) << "a file of the user's\n";
  const auto link = tempPath("link.pcap");
  fs::create_symlink(precious, link);
  refused({"--trace", link}, "a symbolic link");
  EXPECT_EQ(slurp(precious), "a file of the user's\n");
  // A file that is not a capture or a record.
  refused({"--trace", precious}, "exists and is not what this option writes");
  refused({"--machine", "mill", "--record", precious}, "exists and is not what this option writes");
  EXPECT_EQ(slurp(precious), "a file of the user's\n");
  // A FIFO: refused at once, not waited on.
  const auto fifo = tempPath("trace.fifo");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  refused({"--trace", fifo}, "a FIFO");
  // The same file for both.
  const auto both = tempPath("both.pcap");
  refused({"--machine", "mill", "--record", both, "--trace", both}, "exists and is not what this option writes");
  // An earlier run's capture and record are replaced.
  const auto pcap = tempPath("earlier.pcap");
  const auto csv = tempPath("earlier.csv");
  for (int run = 0; run < 2; ++run) {
    Sim sim(test_support::SimOptions{loopback(19), 0, {}, true, state, {"--machine", "mill", "--trace", pcap, "--record", csv}});
    ASSERT_TRUE(sim.up()) << "run " << run;
    EXPECT_EQ(sim.stop(), 0);
  }
  EXPECT_EQ(slurp(pcap).substr(0, 4), std::string("\x4D\x3C\xB2\xA1", 4)) << "a nanosecond pcap, little-endian";
  EXPECT_EQ(slurp(csv).rfind("time_s,", 0), 0U);
  EXPECT_EQ(slurp(state).size(), eeprom.size());
}

// A host cycling the mill over UDP: every servo cycle is a row of the trace,
// in GET /api/machine/trace and in the --record CSV file.
TEST(SimMachine, RecordsEveryServoCycle) {
  const auto csv = tempPath("trace.csv");
  std::size_t cycles = 0;
  json trace;
  {
    Sim sim(loopback(17), {"--machine", "mill", "--record", csv});
    ASSERT_TRUE(sim.up());
    EXPECT_NE(sim.daemon().readUntil("recording:").find("recording: every servo cycle to " + csv), std::string::npos);
    // Not about the 7I77's watchdog: a held-back test is not a stalled host.
    ASSERT_EQ(test_support::patient7i77Watchdogs(sim.address() + ":" + std::to_string(sim.udpPort()), {0, 1}), "");
    HostOnSim host(sim);
    auto& t = host.t;
    auto& ss = host.ss;
    const auto a0 = ss.find(1, "analogout0");
    const auto ena = ss.find(1, "analogena");
    ss.setRaw(ena, 1);
    ss.set(a0, 2.0);  // X at 50 mm/s
    const auto start = sim.get("/api/machine/trace").body["rows"].size();
    for (; cycles < 400; ++cycles) {
      ASSERT_TRUE(ss.cycle().ok);
      t.sleep(1ms);
    }
    const auto m = sim.get("/api/machine").body;
    EXPECT_TRUE(axisNamed(m, "x")["drives"][0]["enabled"].get<bool>());
    EXPECT_NEAR(axisNamed(m, "x")["velocity"].get<double>(), 50.0, 1.0);
    trace = sim.get("/api/machine/trace").body;
    ASSERT_TRUE(trace["rows"].is_array()) << trace.dump().substr(0, 300);
    EXPECT_GE(trace["rows"].size(), start + cycles);
    EXPECT_LE(trace["rows"].size(), start + cycles + 20);
    // The row's time as the API gave it (to the nanosecond: the plant's
    // spans end where the host's datagrams came).
    const std::string since = trace["rows"][trace["rows"].size() - 10][0].dump();
    EXPECT_EQ(sim.get("/api/machine/trace?since=" + since).body["rows"].size(), 9U);
    ss.set(a0, 0.0);
    ss.setRaw(ena, 0);
    ASSERT_TRUE(ss.cycle().ok);
    EXPECT_EQ(sim.stopWithin(2000ms), 0);
  }
  const std::vector<std::string> columns{"time_s", "x_command_volts", "x_command_velocity", "x_position",
                                         "x_velocity", "x_following_error"};
  for (std::size_t i = 0; i < columns.size(); ++i) EXPECT_EQ(trace["columns"][i], columns[i]);
  EXPECT_EQ(trace["columns"].back(), "spindle_rpm");
  // The CSV: the same columns, a row per cycle, numbers that make sense.
  std::ifstream in(csv);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  std::string header;
  for (const auto& c : trace["columns"]) header += (header.empty() ? "" : ",") + c.get<std::string>();
  EXPECT_EQ(line, header);
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::stringstream fields(line);
    std::string f;
    while (std::getline(fields, f, ',')) row.push_back(std::stod(f));
    ASSERT_EQ(row.size(), trace["columns"].size()) << line;
    rows.push_back(row);
  }
  std::filesystem::remove(csv);
  ASSERT_GE(rows.size(), cycles);
  EXPECT_LE(rows.size(), cycles + 30);
  for (std::size_t i = 1; i < rows.size(); ++i) ASSERT_GT(rows[i][0], rows[i - 1][0]) << "row " << i;
  std::size_t moving = 0;
  for (const auto& row : rows) {
    if (row[1] < 1.99) continue;  // before the 2 V came
    ++moving;
    EXPECT_NEAR(row[1], 2.0, 0.01);
    EXPECT_NEAR(row[2], 50.0, 0.5);  // 2 V at 25 mm/s per volt
    EXPECT_GE(row[3], 200.0);
    EXPECT_LE(row[4], 60.0);  // the drive's velocity loop overshoots a little, then settles
    EXPECT_GT(row[5], -0.05);  // it lags its command, a little, and catches up
    EXPECT_LT(row[5], 0.5);
  }
  EXPECT_GE(moving, cycles - 5);
  // The last row at 2 V (the rows after it follow the 0 V that ended the
  // test, and how far X has slowed by then depends on when they were taken).
  const auto lastMoving = std::find_if(rows.rbegin(), rows.rend(), [](const auto& row) { return row[1] >= 1.99; });
  ASSERT_NE(lastMoving, rows.rend());
  EXPECT_NEAR((*lastMoving)[4], 50.0, 0.5);
  EXPECT_GT((*lastMoving)[3], 210.0);  // 400 ms at up to 50 mm/s
  EXPECT_NEAR(rows.back()[8], 150.0, 1e-9);  // Y stayed
}

}  // namespace
