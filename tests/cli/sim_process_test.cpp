// SPDX-License-Identifier: MIT
// `lbpkit sim` as a process: its LBP16 port under garbage, its shutdown
// whatever clients do, a card thread that sleeps when nobody talks to it
// and never locks up under load, the CPU wake-up latency it holds, and one
// process serving several cards, with their binds and state files. Each
// test starts its own sim on a loopback address of its own and stops it
// before it ends.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "hostmot2/muxed_encoder.hpp"
#include "support/process.hpp"
#include "support/sim_api.hpp"
#include "support/sim_child.hpp"
#include "support/temp_dir.hpp"
#include "support/wait.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

namespace {

using namespace std::chrono_literals;
using namespace test_support::sim_api;

// --- The sim on the LBP16 port, as lbpkit's own tools see it ------------

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
    // Within 4 s: under the 5 s a request may take to arrive (cpp-httplib's
    // read timeout), which a sim waiting on the dripping client would take,
    // with room for a machine busy compiling, where stopping has taken over
    // 2 s.
    EXPECT_EQ(sim.stopWithin(4000ms, sig), 0) << "signal " << sig;
    done = true;
    drip.join();
  }
}

// --- A card nobody talks to ---------------------------------------------

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

// --- One process, several cards: binds and state files ------------------

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

}  // namespace
