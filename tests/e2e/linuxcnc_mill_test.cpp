// SPDX-License-Identifier: MIT
// The end-to-end test: the complete LinuxCNC configuration in
// examples/linuxcnc/mill/ (unmodified but for its DISPLAY line) against
// `lbpkit sim --machine mill`. Our headless display, tests/e2e/mill_display.py,
// operates LinuxCNC through its Python module and reports each step as a JSON
// line; this test asserts on them and, once the display has a move going,
// kills LinuxCNC outright and watches the machine through the control API.
//
// The network is the interop tests' (support/interop.hpp): Debian's hm2_eth
// cannot use loopback, so LinuxCNC runs in a network namespace joined to the
// card by a veth pair, the card at the 7I92's usual 10.10.10.10 as the INI
// names it (the stepper mill's copy at 10.10.10.11, so that the two can run
// side by side). hm2_eth's iptables rules refuse any other traffic to the card's
// link, so the control API is on a second link, as a PC's office network
// would be. LinuxCNC also gets PID, IPC and mount namespaces of its own: its
// /tmp is the test's directory, its HAL shared memory and NML segments go with
// it, and killing the namespace's first process kills every last one of its
// processes at once (the "PC crash" the watchdog test needs, and a cleanup
// that cannot leave rtapi_app behind).
#include <fcntl.h>
#include <sched.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "linuxcnc/network_namespace.hpp"
#include "linuxcnc/servo_priority.hpp"
#include "support/card_cpu.hpp"
#include "support/linuxcnc_release.hpp"
#include "support/process.hpp"
#include "support/sim_child.hpp"

namespace {

using namespace std::chrono_literals;
using nlohmann::json;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr double kWatchdog = 0.050;        // the 7I77's analog and field I/O watchdog, s
// mm: the bound on LinuxCNC's following error over every servo period of
// the program. On the host clock each period moves the machine one nominal
// period whatever this kernel's scheduling (no real-time kernel here), so the
// error is the tuned loop's alone: about 0.03 mm on each axis of the mill's
// program, as on an on-time real-time machine. Twice that is the bound; the
// configuration's MIN_FERROR (1 mm) is where a real LinuxCNC would stop.
constexpr double kFerrorBound = 0.06;
// LinuxCNC and the sim's card thread share a CPU (support/card_cpu.hpp):
// the one before the last, since a public configuration's `lbpkit linuxcnc`
// (the last, its default) may run beside a mill (scripts/test: ctest -j 2).
const unsigned kCardCpu = test_support::cardCpu(1);
constexpr auto kRunLimit = 100s;           // one run of the display, start to "ready_for_kill"

// A shell command's exit status; its output is dropped (only `ip`, `sh -c
// command -v` and the like run through here).
int shell(const std::string& command) {
  const int status = std::system((command + " >/dev/null 2>&1 </dev/null").c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

bool installed(const char* tool) { return lbpkit::process::systemProgram(tool).has_value(); }

// The network: a namespace for LinuxCNC, the card's link (10.10.10.0/24, the
// card at `card` on our side, LinuxCNC at `host` inside) and the API's link
// (10.214.N.0/30, N the card address's last number). Removed with the
// object. Runs side by side (ctest -j 2: the two mills, a public
// configuration beside them) take different addresses for all three: the
// card's is where its sim answers on this PC (tests/CMakeLists.txt locks
// each), LinuxCNC's has a route of its own here, from the top of the /24
// down, since `lbpkit linuxcnc` beside it takes its LinuxCNC's from .2 up.
class Network {
 public:
  Network(const std::string& card, const std::string& host) {
    const auto id = std::to_string(::getpid());
    const auto api = "10.214." + card.substr(card.rfind('.') + 1) + ".";
    apiAddress_ = api + "1";
    try {
      ns_ = std::make_unique<lbpkit::linuxcnc::NetworkNamespace>(
          "lbpkit-mill-" + id,
          std::vector<lbpkit::linuxcnc::VethLink>{{"lbm" + id + "c", card + "/32", host + "/24", host + "/32"},
                                                  {"lbm" + id + "a", apiAddress_ + "/30", api + "2/30", {}}});
    } catch (const std::exception& e) {
      problem_ = e.what();
    }
  }
  void remove() {
    if (ns_) ns_->remove();
  }

  [[nodiscard]] bool ok() const { return ns_ != nullptr; }
  [[nodiscard]] const std::string& problem() const { return problem_; }
  [[nodiscard]] const std::string& ns() const { return ns_->name(); }
  [[nodiscard]] const std::string& apiAddress() const { return apiAddress_; }
  [[nodiscard]] unsigned long inode() const { return ns_->inode(); }
  [[nodiscard]] bool gone() const { return ns_->gone(); }

 private:
  std::unique_ptr<lbpkit::linuxcnc::NetworkNamespace> ns_;
  std::string apiAddress_, problem_;
};

// The namespace a process is in (an inode number), or 0.
unsigned long namespaceOf(const std::string& proc, const char* kind) {
  struct stat st {};
  return ::stat(("/proc/" + proc + "/ns/" + kind).c_str(), &st) == 0 ? static_cast<unsigned long>(st.st_ino) : 0;
}

// LinuxCNC's uspace servo thread runs SCHED_OTHER here (rtapi_app cannot
// raise its own priority: no RLIMIT_RTPRIO): lbpkit_linuxcnc's
// ServoThreadPriority gives the namespace's rtapi_app threads SCHED_FIFO
// from outside, below the card thread, as the real-time kernel would.
using lbpkit::linuxcnc::ServoThreadPriority;

std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// How many processes are in the PID namespace `pidNs` or the network
// namespace `netNs`.
int processesIn(unsigned long pidNs, unsigned long netNs) {
  int n = 0;
  std::error_code ec;
  for (const auto& p : fs::directory_iterator("/proc", ec)) {
    const auto name = p.path().filename().string();
    if (name.empty() || !std::isdigit(static_cast<unsigned char>(name[0]))) continue;
    if ((pidNs != 0 && namespaceOf(name, "pid") == pidNs) || (netNs != 0 && namespaceOf(name, "net") == netNs)) ++n;
  }
  return n;
}

// One run of `linuxcnc` on a copy of an example configuration
// (examples/linuxcnc/<config>), our display given `displayArguments` more.
class LinuxCncRun {
 public:
  LinuxCncRun(const Network& net, const std::string& apiUrl, const std::string& config,
              const std::string& displayArguments, const std::string& cardAddress) {
    char tmpl[] = "/tmp/lbpkit-mill-XXXXXX";
    dir_ = ::mkdtemp(tmpl);
    fs::permissions(dir_, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                              fs::perms::others_read | fs::perms::others_exec);
    const fs::path tmp = dir_ / "tmp";  // LinuxCNC's /tmp
    fs::create_directories(tmp);
    fs::permissions(tmp, fs::perms::all | fs::perms::sticky_bit);  // rtapi_app makes its socket as uid 65534
    const fs::path source = LBPKIT_SOURCE_DIR;
    fs::copy(source / "examples/linuxcnc" / config, tmp / "config", fs::copy_options::recursive);
    fs::create_directories(tmp / "e2e");
    fs::copy_file(source / "tests/e2e/mill_display.py", tmp / "e2e/mill_display.py");
    fs::copy_file(source / "tests/e2e/display.py", tmp / "e2e/display.py");  // the general display it builds on
    fs::copy_file(source / "apps/lbpkit/rehearse_driver.py", tmp / "e2e/rehearse_driver.py");  // and that on
    fs::copy_file(source / "tests/e2e/mill_program.ngc", tmp / "e2e/mill_program.ngc");
    fs::permissions(tmp / "e2e/mill_display.py", fs::perms::owner_all | fs::perms::group_read |
                                                      fs::perms::group_exec | fs::perms::others_read |
                                                      fs::perms::others_exec);
    // Only the DISPLAY line changes.
    // LBPKIT_FERROR_DUMP=FILE: every servo period of the program (the HAL
    // sampler's lines: the three joints' f-error, motion.servo.last-period
    // in CPU cycles, packet-error) copied to FILE at the end, to look into.
    const std::string dump = std::getenv("LBPKIT_FERROR_DUMP") ? " --ferror-dump /tmp/ferror.txt" : "";
    const std::string display = "DISPLAY = /tmp/e2e/mill_display.py --api " + apiUrl +
                                " --out /tmp/results.jsonl --program /tmp/e2e/mill_program.ngc" + displayArguments +
                                dump;
    const std::string ini = slurp(tmp / "config/mill.ini");
    const std::regex line(R"(^DISPLAY = .*$)", std::regex::multiline);
    displayLines_ = static_cast<int>(std::distance(std::sregex_iterator(ini.begin(), ini.end(), line), {}));
    // And the card's address ([HM2]IPADDRESS, hm2_eth's board_ip).
    const std::regex address(R"(^IPADDRESS = 10\.10\.10\.10$)", std::regex::multiline);
    std::ofstream(tmp / "config/mill.ini")
        << std::regex_replace(std::regex_replace(ini, line, display), address, "IPADDRESS = " + cardAddress);

    const std::string run = "env -u DISPLAY HOME=/tmp RTAPI_UID=65534 RTAPI_FIFO_PATH=/tmp/rtapi_fifo linuxcnc -r "
                            "/tmp/config/mill.ini";
    std::vector<std::string> argv = {"ip",           "netns",         "exec",    net.ns(),  "unshare", "--pid",
                                     "--fork",       "--kill-child=SIGKILL", "--mount-proc", "--ipc", "--mount"};
    // Its own /tmp: bound here, or, for another release's LinuxCNC, by the
    // helper that enters its root (support/linuxcnc_release.hpp), since the
    // helper lives in a folder a /tmp bound over it might hide.
    const auto root = test_support::inLinuxCncRootArgs();
    if (root.empty()) {
      argv.insert(argv.end(), {"sh", "-c", "mount --bind " + tmp.string() + " /tmp && exec " + run});
    } else {
      argv.insert(argv.end(), {root[0], "--tmp", tmp.string(), root[1], "sh", "-c", "exec " + run});
    }
    const int log = ::open((dir_ / "linuxcnc.log").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(log, 1);
      ::dup2(log, 2);
      ::setsid();
      test_support::runOnCpu(kCardCpu);  // LinuxCNC with the card thread
      std::vector<char*> args;
      for (auto& a : argv) args.push_back(a.data());
      args.push_back(nullptr);
      ::execvp(args[0], args.data());
      ::_exit(127);
    }
    ::close(log);
    netNs_ = net.inode();
  }
  ~LinuxCncRun() {
    kill();
    std::error_code ec;
    if (const char* dump = std::getenv("LBPKIT_FERROR_DUMP"))
      fs::copy_file(dir_ / "tmp/ferror.txt", dump, fs::copy_options::overwrite_existing, ec);
    fs::remove_all(dir_, ec);
  }
  LinuxCncRun(const LinuxCncRun&) = delete;
  LinuxCncRun& operator=(const LinuxCncRun&) = delete;

  [[nodiscard]] int displayLines() const { return displayLines_; }
  [[nodiscard]] std::string log() const { return slurp(dir_ / "linuxcnc.log"); }

  // The display's reports so far, by step (a step that repeats: the last
  // one; "mdi": all of them).
  std::map<std::string, json> reports(std::vector<json>* mdi = nullptr) const {
    std::map<std::string, json> out;
    std::istringstream in(slurp(dir_ / "tmp/results.jsonl"));
    std::string l;
    while (std::getline(in, l)) {
      auto j = json::parse(l, nullptr, false);
      if (j.is_discarded() || !j.contains("step")) continue;
      if (mdi != nullptr && j["step"] == "mdi") mdi->push_back(j);
      out[j["step"].get<std::string>()] = j;
    }
    return out;
  }

  // Waits for the display's last step, its failure, or LinuxCNC's end.
  bool waitForKillPoint(std::chrono::seconds limit, const char* last = "ready_for_kill") {
    const auto end = Clock::now() + limit;
    while (Clock::now() < end) {
      const auto r = reports();
      if (r.count(last)) return true;
      if (r.count("exception") || !alive()) return false;
      std::this_thread::sleep_for(100ms);
    }
    return false;
  }

  // The PID namespace LinuxCNC runs in (its first process's), while it runs.
  [[nodiscard]] unsigned long pidNamespace() const {
    const auto children = slurp("/proc/" + std::to_string(pid_) + "/task/" + std::to_string(pid_) + "/children");
    return children.empty() ? 0 : namespaceOf(children.substr(0, children.find(' ')), "pid");
  }
  [[nodiscard]] unsigned long netNamespace() const { return netNs_; }

  [[nodiscard]] bool alive() const { return pid_ > 0 && ::waitpid(pid_, nullptr, WNOHANG) == 0; }

  // Every LinuxCNC process at once: unshare's child (the namespace's first
  // process) dies with unshare, and the kernel kills the rest of the
  // namespace with it.
  void kill() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }

 private:
  fs::path dir_;
  pid_t pid_ = -1;
  int displayLines_ = 0;
  unsigned long netNs_ = 0;
};

// What the kill did to the machine, from the control API.
struct AfterKill {
  bool moving = false;           // an axis moved at the kill
  double lastCommand = -1;       // s, simulated: the host's last DoIt to the analog channel
  double stillOn = -1;           // s: the last look that saw an enable or a voltage
  double seenOff = -1;           // s: the first look that saw all off
  bool stopped = false;          // every axis came to rest
  double stopTime = -1;          // s after the first look that saw all off
  json atKill, atOff, atRest;
};

bool outputsOff(const json& state) {
  for (const auto& o : state["daughtercards"][0]["analog"]["outputs"])
    if (o["enable"] == true || o["volts"].get<double>() != 0.0) return false;
  for (const auto& a : state["machine"]["axes"])
    for (const auto& d : a["drives"])
      if (d["ena"] == true) return false;
  return true;
}

AfterKill killAndWatch(LinuxCncRun& run, test_support::SimChild& sim) {
  AfterKill k;
  k.atKill = sim.get("/api/state");
  for (const auto& a : k.atKill["machine"]["axes"])
    if (std::abs(a["velocity"].get<double>()) > 10.0) k.moving = true;
  const double killedAt = k.atKill["time_s"].get<double>();
  run.kill();
  const auto end = Clock::now() + 3s;
  while (Clock::now() < end) {
    const auto s = sim.get("/api/state");
    if (s.is_null()) continue;
    if (!outputsOff(s)) {
      k.stillOn = s["time_s"].get<double>();
      continue;
    }
    k.seenOff = s["time_s"].get<double>();
    k.atOff = s;
    break;
  }
  const auto trace = sim.get("/api/machine/trace?since=" + std::to_string(killedAt - 1.0));
  if (!trace.is_null() && !trace["rows"].empty()) k.lastCommand = trace["rows"].back()[0].get<double>();
  while (Clock::now() < end + 3s) {
    const auto m = sim.get("/api/machine");
    bool rest = !m.is_null();
    for (const auto& a : m["axes"]) rest = rest && a["velocity"].get<double>() == 0.0;
    if (rest) {
      k.stopped = true;
      k.stopTime = m["time_s"].get<double>() - k.seenOff;
      k.atRest = m;
      break;
    }
    std::this_thread::sleep_for(10ms);
  }
  return k;
}

// Why a run stopped short: hostmot2 gave the link up,
// its watchdog bit, or the smart-serial port stopped (the PC's servo thread or
// the card thread fell far behind), as the display's last report and
// LinuxCNC's log say.
std::string hostTrouble(const std::map<std::string, json>& r, const std::vector<json>& mdi, const std::string& log) {
  // A following error while the machine ran as it should (homing, MDI, the
  // program): LinuxCNC's servo thread (not real-time on this kernel) came
  // late, the drives ran on at their last command meanwhile, and the error
  // outgrew MIN_FERROR (on the host clock a late period moves the
  // machine one nominal period, so this means the loop itself failed).
  auto followingError = [](const json& j) {
    if (j.contains("messages"))
      for (const auto& m : j["messages"])
        if (m.get<std::string>().find("following error") != std::string::npos) return true;
    return false;
  };
  for (const char* step : {"home", "program", "stepper_z"})
    if (r.count(step) && followingError(r.at(step)))
      return std::string(step) + ": a following error (" +
             r.at(step).value("ferror", json::object()).dump() + ")";
  for (const auto& j : mdi)
    if (followingError(j)) return "mdi " + j.value("command", std::string()) + ": a following error";
  for (const auto& [step, j] : r) {
    if (!j.contains("hm2")) continue;
    const auto& h = j["hm2"];
    if (h.value("io_error", false)) return step + ": hm2_eth io_error (" + h.dump() + ")";
    if (h.value("watchdog.has_bit", false)) return step + ": the 7I92's watchdog bit";
    if (h.contains("sserial.port-0.port_state") && h["sserial.port-0.port_state"] != 3)
      return step + ": smart-serial port stopped (" + h.dump() + ")";
  }
  if (log.find("USRMOT: ERROR: command timeout") != std::string::npos) return "the servo thread stopped running";
  return {};
}

// What LinuxCNC said at a step, less its notes about its own servo thread's
// timing: hm2's "DoIt not cleared from previous servo thread" comes when a
// late period is followed at once by the next, whose read then finds the
// 7I77's DoIt still running, as a real card would (on this kernel the servo
// thread is not real-time; the late periods are counted and reported apart).
std::vector<std::string> messages(const json& j, const char* key = "messages") {
  std::vector<std::string> out;
  if (j.contains(key))
    for (const auto& m : j[key]) {
      auto text = m.get<std::string>();
      if (text.find("DoIt not cleared from previous servo thread") != std::string::npos) continue;
      out.push_back(std::move(text));
    }
  return out;
}

void expectWithinOneCount(const json& cmp, const std::string& what) {
  ASSERT_TRUE(cmp.contains("error_counts")) << what << ": " << cmp.dump();
  for (std::size_t i = 0; i < 3; ++i)
    EXPECT_LE(std::abs(cmp["error_counts"][i].get<double>()), 1.0)
        << what << ": axis " << "xyz"[i] << " is " << cmp["error_counts"][i] << " counts from the commanded position ("
        << cmp["commanded"][i] << " mm commanded, " << cmp["model"][i] << " mm true)";
}

// Homing, the MDI moves and the program: LinuxCNC's coordinates on the
// machine's, every move ending within one count (one step on a stepper
// joint) of where it was sent, the spindle and coolant as programmed, and
// the following error over the program's on-time servo periods under
// MIN_FERROR.
void expectHomedAndRan(std::map<std::string, json>& r, const std::vector<json>& mdi, const char* name) {
  // Homing (switch, then index on a servo joint) puts LinuxCNC's coordinates
  // on the machine's.
  const auto& home = r["home"];
  EXPECT_EQ(home["ok"], true) << home.dump();
  EXPECT_EQ(home["homed"], json::parse("[1,1,1]"));
  expectWithinOneCount(home, "after homing");

  // MDI moves end within one count of where they were sent.
  ASSERT_EQ(mdi.size(), 3U);
  for (const auto& m : mdi) {
    EXPECT_EQ(m["ok"], true) << m.dump();
    EXPECT_TRUE(messages(m).empty()) << m.dump();
    expectWithinOneCount(m, m["command"].get<std::string>());
  }

  // The program: finished, ends in place, spindle and coolant as programmed,
  // and the following error stays small.
  const auto& prog = r["program"];
  EXPECT_EQ(prog["ok"], true) << prog.dump();
  EXPECT_TRUE(messages(prog).empty()) << prog.dump();
  expectWithinOneCount(prog, "at the end of the program");
  EXPECT_NEAR(prog["spindle_rpm_max"].get<double>(), 6000.0, 6000.0 * 0.02) << "S6000";
  EXPECT_EQ(prog["coolant_seen"], true);
  EXPECT_EQ(prog["spindle_running_after"], false);
  EXPECT_EQ(prog["coolant_after"], false);
  const auto& fe = prog["ferror"];
  ASSERT_TRUE(fe.contains("max_ferror_mm")) << prog.dump();
  // LinuxCNC's own timing (its servo thread is not real-time here) is
  // printed beside it: on the host clock it does not move the machine.
  std::printf("LinuxCNC %s: the program took %.1f s; largest following error X/Y/Z %.4f/%.4f/%.4f mm over all "
              "%d servo periods (LinuxCNC's servo thread: %d periods late by over 20 %%, longest %.1f ms; %d "
              "without feedback)\n",
              name, prog["seconds"].get<double>(), fe["max_ferror_mm"][0].get<double>(),
              fe["max_ferror_mm"][1].get<double>(), fe["max_ferror_mm"][2].get<double>(), fe["periods"].get<int>(),
              fe["late_periods"].get<int>(), fe["longest_period_ms"].get<double>(),
              fe["lost_packet_periods"].get<int>());
  EXPECT_GT(fe["periods"].get<int>(), 1000) << "too few servo periods";
  // A period whose read hm2_eth gave up on (LinuxCNC's servo thread held
  // back past packet-read-timeout between its read and the reply the sim
  // had sent) runs without feedback: LinuxCNC's lateness, not the loop's.
  // The bound holds over every period with feedback, and the few after a
  // lost one (mill_display.py: SETTLE) are counted and printed.
  for (std::size_t i = 0; i < 3; ++i)
    EXPECT_LT(fe["max_ferror_with_feedback_mm"][i].get<double>(), kFerrorBound)
        << "axis " << "xyz"[i] << " over every period with feedback";
  if (fe["lost_packet_periods"].get<int>() > 0)
    std::printf("LinuxCNC %s: %d periods without feedback (hm2_eth's read given up), %d periods after them set "
                "aside; with them the largest following error is %.4f/%.4f/%.4f mm\n",
                name, fe["lost_packet_periods"].get<int>(), fe["periods_after_lost_packets"].get<int>(),
                fe["max_ferror_mm"][0].get<double>(), fe["max_ferror_mm"][1].get<double>(),
                fe["max_ferror_mm"][2].get<double>());

}

// What it takes to run the whole of LinuxCNC here; empty when all is there.
std::string whyNotRunnable() {
  if (::geteuid() != 0) return "network namespaces need root";
  for (const char* tool : {"linuxcnc", "halcmd"})
    if (!test_support::haveClientProgram(tool)) return std::string(tool) + " is not installed (linuxcnc-uspace)";
  for (const char* tool : {"ip", "unshare"})
    if (!installed(tool)) return std::string(tool) + " is not installed (iproute2, util-linux)";
  if (shell(test_support::inLinuxCncRoot() + "/usr/bin/python3 -c 'import linuxcnc, hal'") != 0)
    return "LinuxCNC's Python module is not installed for /usr/bin/python3";
  return {};
}

// One scenario: `lbpkit sim` with `simArguments`, LinuxCNC on
// examples/linuxcnc/<config> with our display, until the display's `last`
// step (or its failure); `atLast` runs then, while LinuxCNC still runs.
struct Scenario {
  std::vector<std::string> simArguments;
  std::string config;
  std::string displayArguments;
  const char* last;
  std::function<void(LinuxCncRun&, test_support::SimChild&)> atLast;
  std::string cardAddress = "10.10.10.10";  // the INI's; tests/CMakeLists.txt locks each mill's
  std::string hostAddress = "10.10.10.250";  // LinuxCNC's side of the link (Network)
};
struct Outcome {
  std::map<std::string, json> reports;  // by step
  std::vector<json> mdi;
  std::string log;      // LinuxCNC's output
  std::string trouble;  // the host lost the run (hostTrouble); empty: it ran
  bool setUp = false;   // the network, the sim and the configuration were there
};

std::vector<std::string> withCardCpu(std::vector<std::string> arguments) {
  return test_support::withCardCpu(std::move(arguments), kCardCpu);
}

// One run of a scenario, once: the sim runs on the host clock (`--clock
// host=1ms`, docs/clocks.md), so LinuxCNC's late servo periods on this
// kernel move the machine one nominal period each, as an on-time real-time
// machine would, and what the run shows is the machine and the
// configuration. It ends with nothing of it left: LinuxCNC's processes, the
// sim, the network namespace (checked).
Outcome runScenario(const Scenario& scenario) {
  Outcome o;
  Network net(scenario.cardAddress, scenario.hostAddress);
  if (!net.ok()) {
    ADD_FAILURE() << net.problem();
    return o;
  }
  // The card at the INI's address on hm2_eth's port, its API on the test's
  // own link, at the priority a user runs it; its state in a folder of its own.
  test_support::SimChild sim(
      test_support::SimOptions{scenario.cardAddress, -1, net.apiAddress(), false, {}, withCardCpu(scenario.simArguments)});
  if (!sim.up()) {
    ADD_FAILURE() << "lbpkit sim did not start";
    return o;
  }
  unsigned long pidNs = 0, netNs = 0;
  {
    ServoThreadPriority priority(net.inode());
    LinuxCncRun run(net, sim.url(""), scenario.config, scenario.displayArguments, scenario.cardAddress);
    o.setUp = run.displayLines() == 1;
    EXPECT_EQ(run.displayLines(), 1) << scenario.config << "/mill.ini should have one DISPLAY line";
    const bool reached = o.setUp && run.waitForKillPoint(kRunLimit, scenario.last);
    pidNs = run.pidNamespace();
    netNs = run.netNamespace();
    if (reached && scenario.atLast) scenario.atLast(run, sim);
    run.kill();
    o.reports = run.reports(&o.mdi);
    o.log = run.log();
    o.trouble = hostTrouble(o.reports, o.mdi, o.log);
  }
  // Nothing of LinuxCNC is left (its namespace died with it).
  const auto deadline = Clock::now() + 3s;
  while (processesIn(pidNs, netNs) > 0 && Clock::now() < deadline) std::this_thread::sleep_for(50ms);
  EXPECT_EQ(processesIn(pidNs, netNs), 0) << "LinuxCNC processes outlived the kill";
  EXPECT_EQ(sim.stopWithin(5000ms), 0);
  net.remove();
  EXPECT_TRUE(net.gone()) << "the network namespace or a veth outlived the test";
  return o;
}

TEST(LinuxCncMill, RunsGcodeAndRehearsesFaultsAgainstTheVirtualMill) {
  if (const auto why = whyNotRunnable(); !why.empty()) GTEST_SKIP() << why;
  const auto started = Clock::now();
  AfterKill k;
  const Outcome o = runScenario({{"--machine", "mill", "--clock", "host=1ms"}, "mill", "", "ready_for_kill",
                                 [&k](LinuxCncRun& run, test_support::SimChild& sim) { k = killAndWatch(run, sim); }});
  ASSERT_TRUE(o.setUp);
  auto r = o.reports;
  const auto& mdi = o.mdi;
  const auto& log = o.log;
  const auto& trouble = o.trouble;
  const std::string context = "\n--- LinuxCNC's output ---\n" + log.substr(log.size() > 6000 ? log.size() - 6000 : 0);
  ASSERT_TRUE(trouble.empty()) << trouble << context;
  ASSERT_TRUE(r.count("ready_for_kill")) << "the display did not get through its steps" << context;

  // E-stop reset and Machine On: the drives are enabled, Z's brake released.
  const auto& on = r["machine_on"];
  EXPECT_EQ(on["estop_reset"], true);
  EXPECT_EQ(on["on"], true);
  EXPECT_EQ(on["drive_ena"], json::parse(R"({"x":[true],"y":[true],"z":[true]})")) << on.dump();
  EXPECT_EQ(on["z_brake_engaged"], false);
  EXPECT_EQ(on["lube"], true);

  expectHomedAndRan(r, mdi, "mill");

  // A push while the drives hold the axis: LinuxCNC's first report is the
  // following error (not a limit), and the machine goes off.
  const auto& push = r["push_under_power"];
  const auto pushMessages = messages(push);
  ASSERT_FALSE(pushMessages.empty()) << push.dump();
  EXPECT_EQ(pushMessages.front(), "joint 0 following error") << push.dump();
  EXPECT_EQ(push["machine_off"], true);
  EXPECT_NEAR(push["x_after"].get<double>() - push["x_before"].get<double>(), 3.0, 0.05);

  // The limit switch: X pushed onto it while the machine is off; Machine On
  // is refused with LinuxCNC's limit error; override, jog off, home again.
  const auto& lim = r["limit"];
  EXPECT_EQ(lim["pushed_onto_switch"], true) << lim.dump();
  EXPECT_EQ(lim["x_max_switch"]["tripped"], true);
  EXPECT_EQ(lim["x_max_switch"]["input_on"], false) << "a tripped normally closed switch opens its input";
  EXPECT_EQ(lim["linuxcnc_limit_flags_before_on"][0], 2) << "X on its positive limit, seen from LinuxCNC";
  EXPECT_EQ(lim["machine_on_refused"], true);
  // LinuxCNC's limit error, and at most its soft-limit note besides: X
  // really is past its soft limit, and whether motion's first enabled
  // servo period runs its soft-limit check before the hard-limit fault
  // disables it again is LinuxCNC's own timing (its non-real-time servo
  // thread; motion/control.c reports "Joint must be unhomed, jogged into
  // limits, rehomed" from that check).
  const auto onMessages = messages(lim, "messages_on_machine_on");
  EXPECT_NE(std::find(onMessages.begin(), onMessages.end(), "joint 0 on limit switch error"), onMessages.end())
      << lim.dump();
  for (const auto& m : onMessages)
    EXPECT_TRUE(m == "joint 0 on limit switch error" || m == "Joint must be unhomed, jogged into limits, rehomed" ||
                m.rfind("Exceeded POSITIVE soft limit", 0) == 0)
        << "unexpected at Machine On: " << m;
  EXPECT_EQ(lim["drive_ena_after"]["x"][0], false);
  EXPECT_EQ(lim["recovered_on"], true);
  EXPECT_EQ(lim["limit_flags_after_jog"], json::parse("[0,0,0]"));
  EXPECT_EQ(lim["rehomed"], true);
  expectWithinOneCount(lim["after"], "after homing X again");

  // E-stop during a move: LinuxCNC in E-stop, every enable off, Z braked.
  const auto& es = r["estop"];
  EXPECT_EQ(es["linuxcnc_in_estop"], true) << es.dump();
  EXPECT_EQ(es["estop_ok"], false);
  EXPECT_EQ(es["drive_ena"], json::parse(R"({"x":[false],"y":[false],"z":[false]})"));
  EXPECT_EQ(es["drive_enabled"], json::parse(R"({"x":[false],"y":[false],"z":[false]})"));
  EXPECT_EQ(es["z_brake_engaged"], true);
  EXPECT_EQ(es["reset_after_release"], true);
  EXPECT_EQ(es["on_after_release"], true);

  // A broken encoder channel: the axis runs away until LinuxCNC's following
  // error stops it.
  const auto& enc = r["encoder"];
  const auto encMessages = messages(enc);
  ASSERT_FALSE(encMessages.empty()) << enc.dump();
  EXPECT_EQ(encMessages.front(), "joint 0 following error") << enc.dump();
  EXPECT_EQ(enc["machine_off"], true);
  EXPECT_EQ(enc["drive_ena"]["x"][0], false);
  EXPECT_EQ(enc["x_encoder_broken"], json::parse(R"(["A"])"));
  EXPECT_GT(enc["linuxcnc_x"].get<double>() - enc["model_x"].get<double>(), 1.0)
      << "X ran on while its count stood still";
  EXPECT_EQ(enc["on_after_repair"], true);

  // LinuxCNC killed during a move: the 7I77's watchdog drops the analog
  // outputs to 0 V and the enables within 50 ms of the host's last word, the
  // axes coast to a stop, Z's brake holds.
  EXPECT_EQ(r["ready_for_kill"]["moving"], true);
  EXPECT_TRUE(k.moving) << k.atKill["machine"].dump();
  ASSERT_GT(k.seenOff, 0) << "the outputs did not drop after the kill: " << k.atKill.dump();
  ASSERT_GT(k.lastCommand, 0) << "no servo-cycle trace";
  std::printf("LinuxCNC mill: killed; outputs seen on %.1f ms and seen off %.1f ms after the host's last analog "
              "update (7I77 watchdog: 50 ms); axes at rest %.0f ms later\n",
              k.stillOn > 0 ? (k.stillOn - k.lastCommand) * 1000 : -1.0, (k.seenOff - k.lastCommand) * 1000,
              k.stopTime * 1000);
  // On no later than the watchdog allows (a frame's time more); off when we
  // looked, which may be a little later than it went off.
  if (k.stillOn > 0) {
    EXPECT_LE(k.stillOn - k.lastCommand, kWatchdog + 0.002) << "an output was still on after the watchdog time";
  }
  EXPECT_LE(k.seenOff - k.lastCommand, kWatchdog + 0.1) << "the outputs were not off when we looked";
  ASSERT_TRUE(k.stopped) << "the axes did not come to rest";
  for (std::size_t i = 0; i < 3; ++i) {
    const auto& kill = k.atKill["machine"]["axes"][i];
    const auto& off = k.atOff["machine"]["axes"][i];
    const auto& rest = k.atRest["axes"][i];
    EXPECT_EQ(rest["at_hard_stop"], false) << rest.dump();
    const double v = kill["velocity"].get<double>();
    if (std::abs(v) > 10.0 && kill["name"] != "z") {
      // It went on at least as far as its last command took it until the
      // watchdog, and stopped with nothing driving it.
      EXPECT_GT(std::abs(rest["position"].get<double>() - kill["position"].get<double>()),
                std::abs(v) * kWatchdog * 0.5)
          << "axis " << kill["name"] << " stopped at once instead of coasting";
      // The amplifier is off from the moment the enables drop (the torque
      // shown then may still be that of the plant span the drop fell in),
      // and at rest nothing has driven it since.
      EXPECT_EQ(off["drives"][0]["enabled"], false) << "coasting, nothing drives it: " << off.dump();
      EXPECT_EQ(rest["drives"][0]["torque"].get<double>(), 0.0) << "at rest, nothing drives it: " << rest.dump();
    }
  }
  EXPECT_EQ(k.atRest["axes"][2]["brake_engaged"], true) << "Z hangs on its brake";

  std::printf("LinuxCNC mill: %.0f s in all\n",
              std::chrono::duration<double>(Clock::now() - started).count());
}

// The stepper mill end to end: examples/linuxcnc/mill-7i76, a 7I92T + 7I77 + 7I76
// configuration with servo X and Y on the 7I77 and a stepper Z on StepGen 0,
// timed by the HM2DPLL (stepgen.timer-number 1), Z's switches, its brake and
// the spindle on the 7I76, against examples/machines/mill-7i76.toml: it
// homes, runs the MDI moves and the program, and Z is where its steps put it.
TEST(LinuxCncMill, StepperZOnADpllTimedStepGenHomesAndRunsGcode) {
  if (const auto why = whyNotRunnable(); !why.empty()) GTEST_SKIP() << why;
  const auto started = Clock::now();
  const std::string machine = std::string(LBPKIT_SOURCE_DIR) + "/examples/machines/mill-7i76.toml";
  const Outcome o =
      runScenario({{"--card", "7I92T", "--machine", machine, "--clock", "host=1ms"},
                   "mill-7i76",
                   " --scenario stepper-z",
                   "finished",
                   {},
                   "10.10.10.11",
                   "10.10.10.251"});
  ASSERT_TRUE(o.setUp);
  auto r = o.reports;
  const std::string context =
      "\n--- LinuxCNC's output ---\n" + o.log.substr(o.log.size() > 6000 ? o.log.size() - 6000 : 0);
  ASSERT_TRUE(o.trouble.empty()) << o.trouble << context;
  ASSERT_TRUE(r.count("finished")) << "the display did not get through its steps" << context;

  // Machine On: X and Y's drives enabled; Z has none (its StepGen is enabled
  // by joint.2.amp-enable-out) and its brake (on the 7I76) is released with it.
  const auto& on = r["machine_on"];
  EXPECT_EQ(on["estop_reset"], true);
  EXPECT_EQ(on["on"], true);
  EXPECT_EQ(on["drive_ena"], json::parse(R"({"x":[true],"y":[true],"z":[]})")) << on.dump();
  EXPECT_EQ(on["z_brake_engaged"], false);

  expectHomedAndRan(r, o.mdi, "mill-7i76");

  // Z is where its steps put it: the StepGen's count that hm2 read moved by
  // the steps the motor took, none lost, and both are the command.
  const auto& z = r["stepper_z"];
  EXPECT_EQ(z["ok"], true) << z.dump();
  EXPECT_TRUE(messages(z).empty()) << z.dump();
  EXPECT_EQ(z["timer_number"], 1) << "the StepGens sample on DPLL timer 1";
  EXPECT_DOUBLE_EQ(z["dpll_timer_us"].get<double>(), -100.0);
  const double scale = z["scale"].get<double>();
  EXPECT_DOUBLE_EQ(scale, 320.0);
  const auto& before = z["before"];
  const auto& after = z["after"];
  ASSERT_TRUE(after["stepper"].is_object()) << "the API shows no stepper on Z: " << z.dump();
  EXPECT_EQ(after["stepper"]["lost_steps"], 0) << z.dump();
  EXPECT_EQ(after["stepper"]["stalled"], false);
  const auto machineSteps = after["stepper"]["steps"].get<long>() - before["stepper"]["steps"].get<long>();
  const auto linuxcncCounts = after["counts"].get<long>() - before["counts"].get<long>();
  EXPECT_EQ(linuxcncCounts, machineSteps) << "LinuxCNC's StepGen count and the motor's steps differ: " << z.dump();
  const double commanded = after["commanded_z"].get<double>();
  EXPECT_NEAR(commanded, -123.4567, 1e-9);
  EXPECT_NEAR(static_cast<double>(machineSteps),
              (commanded - before["commanded_z"].get<double>()) * scale, 1.0)
      << "steps for the move";
  // LinuxCNC's feedback (the StepGen's position, in motor coordinates: homing
  // offset them) moved as commanded, and the machine's Z is there.
  EXPECT_NEAR(after["position_fb"].get<double>() - before["position_fb"].get<double>(),
              commanded - before["commanded_z"].get<double>(), 1.0 / scale)
      << "LinuxCNC's feedback, from the count";
  EXPECT_NEAR(after["model_z"].get<double>(), commanded, 1.0 / scale) << "where the machine's Z is";
  std::printf("LinuxCNC mill-7i76: Z to %.4f mm took %ld steps, %ld counted by hm2, %ld lost; Z at %.4f mm; "
              "DPLL phase error %.2f us; %.0f s in all\n",
              commanded, machineSteps, linuxcncCounts, after["stepper"]["lost_steps"].get<long>(),
              after["model_z"].get<double>(), z["dpll_phase_error_us"].get<double>(),
              std::chrono::duration<double>(Clock::now() - started).count());
}

}  // namespace
