// SPDX-License-Identifier: MIT
// `lbpkit monitor` shows the machine behind an `lbpkit sim --machine`:
// the section formatted from GET /api/machine, and the monitor
// asking a control API for it: shown on 200, nothing extra (and no error) on
// 404, without an API, or from an API that never answers.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <signal.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <httplib.h>
#include <stdexcept>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "machine_view.hpp"
#include "support/process.hpp"
#include "support/sim_child.hpp"
#include "support/temp_dir.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;

namespace {

using nlohmann::json;
using test_support::run;

// What `lbpkit sim --machine mill` answers (notes: the API's contract), with
// X at its max limit, the E-stop pressed and the spindle running.
json cannedMill() {
  auto sw = [](const char* name, const char* kind, int input, bool tripped) {
    return json{{"name", name}, {"kind", kind}, {"input", input}, {"tripped", tripped}, {"input_on", !tripped}};
  };
  auto drive = [](int n, double volts, bool ena, int count) {
    return json{{"analog_output", n}, {"command_volts", volts}, {"ena", ena},         {"enabled", ena},
                {"torque", 0.5},      {"encoder_input", n},     {"encoder_count", count}, {"true_counts", 1.0 * count},
                {"encoder_broken", json::array()}};
  };
  json x = {{"name", "x"},
            {"position", 402.12345},
            {"velocity", -1.5},
            {"brake_engaged", false},
            {"at_hard_stop", false},
            {"jammed", false},
            {"pushing", true},
            {"drives", {drive(0, -0.25, true, 1234)}},
            {"switches", {sw("x-home", "home", 0, true), sw("x-min", "min_limit", 1, false), sw("x-max", "max_limit", 2, true)}}};
  json z = {{"name", "z"},
            {"position", -75.0},
            {"velocity", 0.0},
            {"brake_engaged", true},
            {"at_hard_stop", false},
            {"jammed", true},
            {"pushing", false},
            {"drives", {drive(2, 0.0, false, 7)}},
            {"switches", {sw("z-home", "home", 6, false)}}};
  z["drives"][0]["encoder_broken"] = {"A", "index"};
  z["drives"][0]["encoder_reversed"] = true;
  z["drives"][0]["enable_ignored"] = true;
  json m = {{"name", "mill"},
            {"time_s", 12.3456},
            {"axes", {x, z}},
            {"spindle", {{"command_rpm", 12000.0}, {"rpm", 11990.4}, {"revolutions", 10.0}, {"running", true}, {"encoder_count", 4321}}},
            {"estop_ok", false},
            {"probe", true},
            {"outputs", {{{"name", "coolant"}, {"output", 0}, {"on", true}}, {{"name", "lube"}, {"output", 1}, {"on", false}}}}};
  m["switches"] = json::array();
  for (const auto& a : m["axes"])
    for (const auto& s : a["switches"]) m["switches"].push_back(s);
  m["switches"].push_back(sw("estop", "estop", 9, true));
  return m;
}

// A TCP socket on a free loopback port (listening or not); `port` says which.
int loopbackSocket(bool listening, std::string& port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof sa;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&sa), len) != 0 || (listening && ::listen(fd, 4) != 0) ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&sa), &len) != 0)
    throw std::runtime_error("no loopback socket");
  port = std::to_string(ntohs(sa.sin_port));
  return fd;
}

bool has(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

TEST(MonitorView, ShowsAxesSwitchesSpindleAndTheEstopChain) {
  const auto s = app::machineSection(cannedMill());
  EXPECT_TRUE(has(s, "machine: mill at 12.346 s")) << s;
  EXPECT_TRUE(has(s, "E-stop chain: OPEN (E-stop)")) << s;
  EXPECT_TRUE(has(s, "probe: TOUCHING")) << s;
  // Per axis: name, position (3 decimals), velocity, drive volts and enable.
  EXPECT_TRUE(has(s, "  x         402.123     -1.500  AOUT0  -0.250 V  ENA on  enabled   enc0  1234  pushed\n")) << s;
  EXPECT_TRUE(has(s,
                  "  z         -75.000      0.000  AOUT2  +0.000 V  ENA off disabled  enc2     7 broken: A,index"
                  "  encoder reversed  ENA ignored  brake on  JAMMED\n"))
      << s;
  EXPECT_TRUE(has(s, "switches: x-home TRIPPED  x-min -  x-max TRIPPED\n")) << s;
  EXPECT_TRUE(has(s, "switches: z-home -\n")) << s;
  EXPECT_TRUE(has(s, "other switches: estop TRIPPED\n")) << s;  // on no axis, shown once
  EXPECT_FALSE(has(s, "other switches: x-home")) << s;
  EXPECT_TRUE(has(s, "spindle: command 12000 rpm, actual 11990 rpm, running, encoder 4321\n")) << s;
  EXPECT_TRUE(has(s, "outputs:  coolant (out 0) ON  lube (out 1) off\n")) << s;
  // The E-stop chain closed, nothing touching, no spindle (null).
  auto m = cannedMill();
  m["estop_ok"] = true;
  m["probe"] = false;
  m["spindle"] = nullptr;
  const auto calm = app::machineSection(m);
  EXPECT_TRUE(has(calm, "E-stop chain: closed (ok)   probe: clear")) << calm;
  EXPECT_FALSE(has(calm, "spindle:")) << calm;
}

TEST(MonitorView, AnAnswerItDoesNotUnderstandShowsQuestionMarksNotACrash) {
  EXPECT_TRUE(has(app::machineSection(json::object()), "machine: ? at ? s   E-stop chain: ?"));
  auto m = cannedMill();
  m["axes"][0]["position"] = "far";
  m["axes"][0]["drives"] = 3;
  m["axes"][1]["drives"][0] = nullptr;
  m["outputs"][0] = "coolant";
  m["spindle"] = json::array();
  const auto s = app::machineSection(m);
  EXPECT_TRUE(has(s, "  x               ?     -1.500  (no drive)  pushed\n")) << s;
  EXPECT_TRUE(has(s, "AOUT?       ? V  ENA ?   ?         enc?     ?")) << s;
  EXPECT_TRUE(has(s, "outputs:  ? (out ?) ?  lube (out 1) off")) << s;
  EXPECT_NO_THROW((void)app::machineSection(json::array()));
  EXPECT_NO_THROW((void)app::machineSection(json(42)));
}

// A stepper axis (no drives) shows its StepGen's steps, the steps
// its motor lost and a stall; parts wired to the 7I76 say so.
TEST(MonitorView, AStepperAxisShowsItsStepsLostStepsAndStall) {
  auto m = cannedMill();
  auto& z = m["axes"][1];
  z["drives"] = json::array();
  z["jammed"] = false;
  z["brake_engaged"] = false;
  z["stepper"] = {{"stepgen", 0}, {"steps", 4000}, {"lost_steps", 12}, {"stalled", true}, {"commanded_position", -70.0}};
  m["axes"][0]["stepper"] = nullptr;  // a servo axis, as the API says it
  const auto s = app::machineSection(m);
  EXPECT_TRUE(has(s, "  z         -75.000      0.000  StepGen 0: 4000 steps, 12 lost  STALLED\n")) << s;
  EXPECT_TRUE(has(s, "  x         402.123     -1.500  AOUT0  -0.250 V  ENA on  enabled   enc0  1234  pushed\n")) << s;
  z["stepper"]["stalled"] = false;
  z["stepper"]["lost_steps"] = 0;
  const auto following = app::machineSection(m);
  EXPECT_TRUE(has(following, "StepGen 0: 4000 steps, 0 lost\n")) << following;
  EXPECT_FALSE(has(following, "STALLED")) << following;
  // Mistyped: question marks, no crash.
  z["stepper"] = {{"stepgen", "zero"}, {"steps", nullptr}};
  EXPECT_TRUE(has(app::machineSection(m), "StepGen ?: ? steps, ? lost  stall ?\n")) << app::machineSection(m);
}

TEST(MonitorView, PartsWiredToThe7I76SaySo) {
  auto m = cannedMill();
  m["axes"][0]["switches"][2]["daughtercard"] = "7I76";
  m["outputs"][1]["daughtercard"] = "7I76";
  m["outputs"][0]["daughtercard"] = "7I77";
  m["spindle"]["daughtercard"] = "7I76";
  const auto s = app::machineSection(m);
  EXPECT_TRUE(has(s, "switches: x-home TRIPPED  x-min -  x-max (7I76) TRIPPED\n")) << s;
  EXPECT_TRUE(has(s, "outputs:  coolant (out 0) ON  lube (7I76 out 1) off\n")) << s;
  EXPECT_TRUE(has(s, "spindle (7I76): command 12000 rpm")) << s;
}

// A control API of the test's own on a free loopback port, answering
// GET /api/machine with `status` and `body`.
class CannedApi {
 public:
  CannedApi(int status, std::string body) : status_(status), body_(std::move(body)) {
    server_.Get("/api/machine", [this](const httplib::Request&, httplib::Response& res) {
      ++requests_;
      res.status = status_;
      res.set_content(body_, "application/json");
    });
    port_ = server_.bind_to_any_port("127.0.0.1");
    thread_ = std::thread([this] { server_.listen_after_bind(); });
    while (!server_.is_running()) std::this_thread::yield();
  }
  ~CannedApi() {
    server_.stop();
    thread_.join();
  }
  [[nodiscard]] int port() const { return port_; }
  [[nodiscard]] int requests() const { return requests_; }

 private:
  int status_;
  std::string body_;
  httplib::Server server_;
  int port_ = 0;
  std::atomic<int> requests_{0};
  std::thread thread_;
};

TEST(MonitorView, TheMonitorShowsTheMachineItsApiReports) {
  CannedApi api(200, cannedMill().dump());
  const auto r = run({"monitor", "--sim", "--api", "127.0.0.1:" + std::to_string(api.port()), "--frames", "2",
                      "--plain", "--display", "20"},
                     std::chrono::seconds(30));
  ASSERT_EQ(r.exit, 0) << r.err;
  EXPECT_TRUE(has(r.out, "channel 0: 7I77 field I/O")) << r.out;  // the board, then the machine
  EXPECT_TRUE(has(r.out, "machine: mill at 12.346 s")) << r.out;
  EXPECT_TRUE(has(r.out, "switches: x-home TRIPPED  x-min -  x-max TRIPPED")) << r.out;
  EXPECT_TRUE(has(r.out, "spindle: command 12000 rpm")) << r.out;
  EXPECT_GE(api.requests(), 1);
  EXPECT_EQ(r.err, "");
}

TEST(MonitorView, NoMachineNoApiOrNoAnswerShowNothingExtra) {
  CannedApi none(404, R"json({"error": "no machine is loaded (lbpkit sim --machine)"})json");
  // A listening socket nobody accepts on: the request is sent and never
  // answered. And a port nothing listens on (bound, then closed: free).
  std::string deafPort, closedPort;
  const int deaf = loopbackSocket(true, deafPort);
  ::close(loopbackSocket(false, closedPort));
  for (const auto& port : {std::to_string(none.port()), deafPort, closedPort}) {
    const auto r = run({"monitor", "--sim", "--api", "127.0.0.1:" + port, "--frames", "2", "--plain", "--display", "20"},
                       std::chrono::seconds(30));
    EXPECT_EQ(r.exit, 0) << port << ": " << r.err;
    EXPECT_TRUE(has(r.out, "encoders:")) << port << ": " << r.out;
    EXPECT_FALSE(has(r.out, "machine")) << port << ": " << r.out;
    EXPECT_EQ(r.err, "") << port;
  }
  EXPECT_GE(none.requests(), 1);
  ::close(deaf);
  // --no-api asks nobody.
  CannedApi mill(200, cannedMill().dump());
  const auto r = run({"monitor", "--sim", "--no-api", "--frames", "1", "--plain"}, std::chrono::seconds(30));
  EXPECT_EQ(r.exit, 0) << r.err;
  EXPECT_FALSE(has(r.out, "machine")) << r.out;
  EXPECT_EQ(mill.requests(), 0);
}

// The real thing: `lbpkit sim --machine mill` on loopback ports of its own,
// the monitor on its LBP16 port asking its control API.
TEST(MonitorView, TheMonitorShowsTheMillOfARunningSim) {
  const auto state = (std::filesystem::temp_directory_path() / ("lbpkit-monitor-" + std::to_string(::getpid()))).string();
  {
    test_support::Daemon sim({"sim", "--machine", "mill", "--bind", "127.0.0.1:0", "--api", "127.0.0.1:0",
                              "--state", state, "--no-realtime", "--ready-fd", "3"},
                             true);
    const auto card = test_support::greeting(sim)["cards"][0];
    ASSERT_TRUE(card.is_object());
    const auto udp = std::to_string(card["lbp16"]["port"].get<int>());
    const auto apiPort = std::to_string(card["api"]["port"].get<int>());
    const auto r = run({"monitor", "--addr", "127.0.0.1:" + udp, "--api", apiPort, "--frames", "2", "--plain",
                        "--display", "20"},
                       std::chrono::seconds(30));
    EXPECT_EQ(r.exit, 0) << r.err;
    EXPECT_TRUE(has(r.out, "machine: mill at ")) << r.out;
    EXPECT_TRUE(has(r.out, "E-stop chain: closed (ok)")) << r.out;
    // Where machine::mill() puts the axes at power-up, enables off (no host).
    EXPECT_TRUE(has(r.out, "  x         200.000      0.000  AOUT0  +0.000 V  ENA off disabled")) << r.out;
    EXPECT_TRUE(has(r.out, "  z         -75.000")) << r.out;
    EXPECT_TRUE(has(r.out, "switches: x-home -  x-min -  x-max -")) << r.out;
    EXPECT_TRUE(has(r.out, "spindle: command 0 rpm, actual 0 rpm, stopped")) << r.out;
    EXPECT_EQ(sim.stop(), 0);
  }
  test_support::removeStateFiles(state);
}

// The same with a stepper: `lbpkit sim --card 7I92T` (the 7I77+7I76
// firmware, five StepGens) and a machine file whose Z is on StepGen 0.
TEST(MonitorView, TheMonitorShowsTheStepperAxisOfARunningSim) {
  const auto tmp = std::filesystem::temp_directory_path();
  const auto state = (tmp / ("lbpkit-monitor-stepper-" + std::to_string(::getpid()))).string();
  // tests/machines/router_stepper.toml, beside examples/.
  const std::string file = LBPKIT_EXAMPLES_DIR "/../tests/machines/router_stepper.toml";
  {
    test_support::Daemon sim({"sim", "--card", "7I92T", "--machine", file, "--bind", "127.0.0.1:0", "--api",
                              "127.0.0.1:0", "--state", state, "--no-realtime", "--ready-fd", "3"},
                             true);
    const auto card = test_support::greeting(sim)["cards"][0];
    ASSERT_TRUE(card.is_object());
    const auto udp = std::to_string(card["lbp16"]["port"].get<int>());
    const auto r = run({"monitor", "--addr", "127.0.0.1:" + udp, "--api", std::to_string(card["api"]["port"].get<int>()), "--frames", "2",
                        "--plain", "--display", "20"},
                       std::chrono::seconds(30));
    EXPECT_EQ(r.exit, 0) << r.err;
    EXPECT_TRUE(has(r.out, "machine: router at ")) << r.out;
    EXPECT_TRUE(has(r.out, "  x         200.000      0.000  AOUT0  +0.000 V  ENA off disabled")) << r.out;
    EXPECT_TRUE(has(r.out, "  z       -1000.000      0.000  StepGen 0: 0 steps, 0 lost\n")) << r.out;
    EXPECT_EQ(sim.stop(), 0);
  }
  test_support::removeStateFiles(state);
}

TEST(MonitorView, AnApiThatWantsATokenSaysSo) {
  CannedApi locked(401, R"({"error": "unauthorized"})");
  const auto r = run({"monitor", "--sim", "--api", std::to_string(locked.port()), "--frames", "1", "--plain"},
                     std::chrono::seconds(30));
  EXPECT_EQ(r.exit, 0) << r.err;
  EXPECT_TRUE(has(r.out, "wants the sim's API token (--api-token or LBPKIT_API_TOKEN)")) << r.out;
  const auto bad = run({"monitor", "--sim", "--api", "127.0.0.1:http", "--frames", "1"}, std::chrono::seconds(30));
  EXPECT_EQ(bad.exit, 1);
  EXPECT_TRUE(has(bad.err, "--api: \"127.0.0.1:http\" is not [ADDR:]PORT")) << bad.err;
}

}  // namespace

// The monitor's own process held back 200 ms (SIGSTOP, SIGCONT): the 7I77's
// 50 ms watchdog bites on the sim, which runs on the wall clock. The monitor
// says so in its header, counts it and restarts the channels, whose CS is
// clean again on its last screen.
TEST(MonitorView, TheMonitorRecoversFromAStallOfItsOwnAndSaysSo) {
  const auto state = (std::filesystem::temp_directory_path() / ("lbpkit-monitor-stall-" + std::to_string(::getpid()))).string();
  {
    test_support::Daemon sim(
        {"sim", "--bind", "127.0.0.1:0", "--api", "127.0.0.1:0", "--state", state, "--no-realtime", "--ready-fd", "3"},
        true);
    const auto udp = test_support::lbp16Address(sim);
    ASSERT_FALSE(udp.empty());
    test_support::Daemon monitor({"monitor", "--addr", udp, "--no-api", "--plain", "--display", "10"});
    ASSERT_TRUE(has(monitor.readUntil("channel 1: "), "CS: ok")) << "running before the stall";
    ::kill(monitor.pid(), SIGSTOP);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    ::kill(monitor.pid(), SIGCONT);
    // From the first screen that tells of the bite on, the channels run
    // clean again (a later stall of a loaded machine may bite once more):
    // the output is read until both say so, or for 10 s each.
    const auto told = monitor.readUntil("watchdog: ").find("watchdog: ");
    ASSERT_NE(told, std::string::npos) << monitor.readUntil("watchdog: ");
    (void)monitor.readUntil("channel 0: 7I77 field I/O (unit 0x12000AEE)  CS: ok", told);
    const auto out = monitor.readUntil("channel 1: 7I77 analog (unit 0x11000AEE)  CS: ok", told);
    EXPECT_EQ(monitor.stopWithin(std::chrono::seconds(5), SIGINT), 0);
    const auto after = out.substr(told);
    EXPECT_TRUE(has(after.substr(0, after.find('\n')), "channels restarted ")) << after;
    EXPECT_TRUE(has(after, "channel 0: 7I77 field I/O (unit 0x12000AEE)  CS: ok")) << after;
    EXPECT_TRUE(has(after, "channel 1: 7I77 analog (unit 0x11000AEE)  CS: ok")) << after;
    EXPECT_EQ(sim.stop(), 0);
  }
  test_support::removeStateFiles(state);
}
