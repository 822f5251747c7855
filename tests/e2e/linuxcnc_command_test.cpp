// SPDX-License-Identifier: MIT
// `lbpkit linuxcnc CONFIG.ini` on the example mill (examples/linuxcnc/mill),
// its display a script that only waits: LinuxCNC comes up against the sim at
// the configuration's board_ip (its servo thread's DOITs reach the sim), and
// every way out (Ctrl-C, LinuxCNC killed, the sim killed) leaves no network
// namespace, no veth and no process behind. Needs root and linuxcnc-uspace
// (scripts/test installs it).
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <cstdio>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "support/card_cpu.hpp"
#include "support/interop.hpp"
#include "support/sim_child.hpp"
#include "support/temp_dir.hpp"
#include "support/temporary_user.hpp"
#include "support/wait.hpp"
#include "support/xvfb.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using interop::have;
using interop::sh;

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The PID namespace a process is in (an inode number), or 0.
unsigned long pidNamespaceOf(const std::string& pid) {
  struct stat st {};
  return ::stat(("/proc/" + pid + "/ns/pid").c_str(), &st) == 0 ? static_cast<unsigned long>(st.st_ino) : 0;
}

// The processes in PID namespace `ns` (LinuxCNC's: everything it started).
int processesIn(unsigned long ns) {
  int n = 0;
  std::error_code ec;
  for (const auto& p : fs::directory_iterator("/proc", ec)) {
    const auto name = p.path().filename().string();
    if (name.find_first_not_of("0123456789") == std::string::npos && pidNamespaceOf(name) == ns) ++n;
  }
  return n;
}

// The sim's SSLBP DOIT count, from its control API at `url`; 0 without an answer.
unsigned long doits(const std::string& url) {
  std::smatch m;
  if (!std::regex_match(url, m, std::regex(R"(http://([0-9.]+):(\d+))"))) return 0;
  const auto j = test_support::httpGetJson(m[1].str(), std::stoi(m[2]), "/api/state", std::chrono::seconds(2));
  if (!j.is_object()) return 0;
  const auto& n = j["sserial"]["doits"];
  return n.is_number() ? n.get<unsigned long>() : 0;
}

constexpr const char* kCardAddress = "10.10.10.12";

// The folder a run of `lbpkit linuxcnc` with this pid made
// (/tmp/lbpkit-linuxcnc-PID-XXXXXX), or an empty path.
fs::path runFolder(pid_t run) {
  std::error_code ec;
  const std::string prefix = "lbpkit-linuxcnc-" + std::to_string(run) + "-";
  for (const auto& e : fs::directory_iterator("/tmp", ec))
    if (e.path().filename().string().rfind(prefix, 0) == 0) return e.path();
  return {};
}

// What is left of the run with this pid: its network namespace, its link,
// a route to `card`, its folder; empty when nothing is.
std::string leftOf(pid_t run, const std::string& card) {
  std::string left;
  const auto id = std::to_string(run);
  if (fs::exists("/run/netns/lbpkit-linuxcnc-" + id)) left += "network namespace lbpkit-linuxcnc-" + id + "; ";
  if (fs::exists("/sys/class/net/lbl" + id)) left += "link lbl" + id + "; ";
  if (!sh("ip -4 route show exact " + card + "/32").out.empty()) left += "a route to " + card + "; ";
  if (!runFolder(run).empty()) left += "folder " + runFolder(run).string() + "; ";
  return left;
}

// The network namespaces of lbpkit linuxcnc runs there are now.
std::string runNamespaces() {
  std::set<std::string> names;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator("/run/netns", ec))
    if (e.path().filename().string().rfind("lbpkit-linuxcnc-", 0) == 0) names.insert(e.path().filename().string());
  std::string text;
  for (const auto& n : names) text += n + "\n";
  return text;
}

class LinuxCncCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "lbpkit linuxcnc needs root";
    if (!have("linuxcnc") || !have("ip")) GTEST_SKIP() << "linuxcnc-uspace or iproute2 is not installed";
    shmBefore_ = sh("ipcs -m | grep -c -E '^0x'").out;
    // The example configuration, its display a script that waits (LinuxCNC
    // runs `DISPLAY -ini FILE`); readable by rtapi_app's user (nobody).
    fs::permissions(dir_.path(), fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                     fs::perms::others_read | fs::perms::others_exec);
    config_ = dir_.path() / "mill";
    fs::copy(fs::path(LBPKIT_SOURCE_DIR) / "examples/linuxcnc/mill", config_, fs::copy_options::recursive);
    const auto display = dir_.path() / "waiting_display";
    std::ofstream(display) << "#!/bin/sh\nexec sleep 600\n";
    fs::permissions(display, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                 fs::perms::others_read | fs::perms::others_exec);
    const auto ini = slurp(config_ / "mill.ini");
    std::ofstream(config_ / "mill.ini")
        << std::regex_replace(ini, std::regex(R"(^DISPLAY = .*$)", std::regex::multiline), "DISPLAY = " + display.string());
    atAddressOfItsOwn();
  }
  // The card at 10.10.10.12 ([HM2]IPADDRESS), apart from the mills' (tests/CMakeLists.txt).
  void atAddressOfItsOwn() { atAddress(kCardAddress); }
  // The example INI's line that starts with `key` (e.g. "IPADDRESS = ")
  // made `key` + `value`, taken as it is.
  void setLine(const std::string& key, const std::string& value) {
    std::istringstream in(slurp(config_ / "mill.ini"));
    std::string text;
    for (std::string line; std::getline(in, line);) text += (line.rfind(key, 0) == 0 ? key + value : line) + "\n";
    std::ofstream(config_ / "mill.ini") << text;
  }
  // The card's address ([HM2]IPADDRESS), whatever the text.
  void atAddress(const std::string& address) {
    setLine("IPADDRESS = ", address);
  }
  // A display program that ends at once with `status`.
  void displayEndingWith(int status) {
    const auto display = dir_.path() / "ending_display";
    std::ofstream(display) << "#!/bin/sh\nexit " << status << "\n";
    fs::permissions(display, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                 fs::perms::others_read | fs::perms::others_exec);
    setLine("DISPLAY = ", display.string());
  }
  // A display program that says why on standard output and standard
  // error, then ends with status 3.
  void displayFailing() {
    const auto display = dir_.path() / "failing_display";
    std::ofstream(display) << "#!/bin/sh\necho 'the display: no tool table here'\n"
                              "echo 'the display: giving up' >&2\nexit 3\n";
    fs::permissions(display, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                 fs::perms::others_read | fs::perms::others_exec);
    setLine("DISPLAY = ", display.string());
  }
  // In a forked child: lbpkit linuxcnc on the example mill as a user calls
  // it (the machine auto, the CPU last), its output in log_; the sim's
  // state in the test's folder and on the host clock.
  [[noreturn]] void execAsAUser() {
    ::setenv("HOME", dir_.path().c_str(), 1);  // LinuxCNC's files in its user's home: the test's folder
    const int fd = ::open(log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    const std::string ini = (config_ / "mill.ini").string();
    const std::string state = (dir_.path() / "sim.eeprom").string();
    ::execl(LBPKIT_BINARY, LBPKIT_BINARY, "linuxcnc", ini.c_str(), "--", "--state", state.c_str(),
            static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // A HAL pin's value in the running LinuxCNC (halcmd in its namespaces).
  std::string pin(const std::string& name) {
    const auto pids = sh("ip netns pids lbpkit-linuxcnc-" + id_).out;
    const auto first = pids.substr(0, pids.find('\n'));
    if (first.empty()) return {};
    auto value = sh("nsenter -t " + first + " -i -m -n halcmd -s getp " + name).out;
    while (!value.empty() && (value.back() == '\n' || value.back() == ' ')) value.pop_back();
    return value;
  }
  // What is left of the run (pid_) 10 s after a SIGKILL, empty when
  // nothing is: leftOf(), the sim, and LinuxCNC's processes (in `linuxCnc`,
  // its PID namespace, when given).
  std::string killedLeaves(unsigned long linuxCnc = 0) {
    const pid_t run = pid_;
    if (::kill(run, SIGKILL) != 0) return "no run to kill";
    ::waitpid(run, nullptr, 0);
    pid_ = -1;
    std::string left;
    test_support::waitFor(
        [&] {
          left = leftOf(run, kCardAddress);
          if (linuxCnc != 0 && processesIn(linuxCnc) != 0) left += "LinuxCNC's processes; ";
          // ([s]: not the shell that runs pgrep, whose command line holds the words)
          if (!sh("pgrep -f '[s]im --bind " + std::string(kCardAddress) + "'").out.empty()) left += "the sim; ";
          return left.empty();
        },
        10s);
    return left;
  }
  // lbpkit linuxcnc run to its end with `args` after the INI: what it
  // printed (stdout and stderr together) and its exit status.
  test_support::Result runToEnd(const fs::path& ini, std::vector<std::string> args = {}) {
    args.insert(args.begin(), {"linuxcnc", ini.string()});
    auto r = test_support::run(args, 90s);
    r.out += r.err;
    return r;
  }

  // lbpkit linuxcnc started, its output in a file; true once LinuxCNC's
  // servo thread runs the card (the sim has counted DOITs). `display`: the X
  // display LinuxCNC's own display program shows on (DISPLAY), or none.
  bool start(const std::string& display = {}, const fs::path& iniFile = {}, const std::vector<std::string>& more = {}) {
    log_ = dir_.path() / "linuxcnc.log";
    // Its greeting (--ready-fd 3): the sim's API, once LinuxCNC has started.
    int ready[2];
    if (::pipe(ready) != 0) return false;
    pid_ = ::fork();
    id_ = std::to_string(pid_);
    if (pid_ == 0) {
      ::dup2(ready[1], 3);
      // LinuxCNC's files in its user's home (linuxcnc_debug.txt, AXIS's
      // preferences) go to the test's folder.
      ::setenv("HOME", dir_.path().c_str(), 1);
      if (display.empty())
        ::unsetenv("DISPLAY");
      else
        ::setenv("DISPLAY", display.c_str(), 1);
      const int fd = ::open(log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      const std::string ini = (iniFile.empty() ? config_ / "mill.ini" : iniFile).string();
      const std::string state = (dir_.path() / "sim.eeprom").string();
      // The sim on the clock lbpkit linuxcnc chooses for this PC
      // (docs/linuxcnc.md#on-a-pc-without-a-real-time-kernel).
      // On the CPU before the last (tests/CMakeLists.txt locks it): one
      // LinuxCNC a CPU beside the other end-to-end runs.
      const auto cpu = std::to_string(test_support::cardCpu(1));
      std::vector<std::string> words = {LBPKIT_BINARY, "linuxcnc", ini, "--machine", "mill", "--cpu", cpu,
                                        "--ready-fd", "3"};
      words.insert(words.end(), more.begin(), more.end());
      words.insert(words.end(), {"--", "--state", state});
      std::vector<char*> argv;
      for (auto& w : words) argv.push_back(w.data());
      argv.push_back(nullptr);
      ::execv(LBPKIT_BINARY, argv.data());
      ::_exit(127);
    }
    ::close(ready[1]);
    std::string url, greeting;
    const bool up = test_support::waitFor(
        [&] {
          // lbpkit linuxcnc ended before LinuxCNC ran: nothing more to wait
          // for (its log says why).
          int status = 0;
          if (::waitpid(pid_, &status, WNOHANG) == pid_) {
            pid_ = -1;
            return true;
          }
          pollfd p{ready[0], POLLIN, 0};
          char buf[4096];
          ssize_t n = 0;
          if (url.empty() && ::poll(&p, 1, 0) > 0 && (n = ::read(ready[0], buf, sizeof buf)) > 0) {
            greeting.append(buf, static_cast<std::size_t>(n));
            const auto g = nlohmann::json::parse(greeting.substr(0, greeting.find('\n')), nullptr, false);
            if (greeting.find('\n') != std::string::npos && g.is_object())
              url = g["sim"]["cards"][0]["api"]["url"].get<std::string>();
          }
          // Past hm2_eth's discovery (about 1300 DOITs): its servo thread runs.
          return !url.empty() && doits(url) > 3000;
        },
        60s, 200ms);
    ::close(ready[0]);
    if (!up || pid_ <= 0) return false;
    // What to look for afterwards: LinuxCNC's PID namespace, the sim.
    // (in the network namespace, unshare itself is still in ours).
    std::istringstream pids(sh("ip netns pids lbpkit-linuxcnc-" + id_).out);
    for (std::string p; std::getline(pids, p) && linuxCncNs_ == 0;)
      if (const auto ns = pidNamespaceOf(p); ns != 0 && ns != pidNamespaceOf("self")) linuxCncNs_ = ns;
    const auto sim = sh("pgrep -P " + std::to_string(pid_) + " -f 'sim --bind'").out;
    simPid_ = std::atoi(sim.c_str());
    return linuxCncNs_ != 0 && simPid_ > 0;
  }
  // Waits for lbpkit linuxcnc to end: its exit status, -2 if it did not in 30 s.
  int end() {
    int status = 0;
    const bool ended = test_support::waitFor([&] { return ::waitpid(pid_, &status, WNOHANG) == pid_; }, 30s, 50ms);
    if (!ended) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
      return -2;
    }
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  void expectNothingLeft() {
    // HAL's shared memory went with LinuxCNC's IPC namespace.
    EXPECT_EQ(sh("ipcs -m | grep -c -E '^0x'").out, shmBefore_) << sh("ipcs -m").out;
    EXPECT_FALSE(fs::exists("/run/netns/lbpkit-linuxcnc-" + id_)) << slurp(log_);
    EXPECT_FALSE(fs::exists("/sys/class/net/lbl" + id_));
    // Nothing of LinuxCNC's (its PID namespace is empty) and no sim.
    EXPECT_TRUE(test_support::waitFor(
        [&] { return processesIn(linuxCncNs_) == 0 && ::kill(simPid_, 0) != 0; }, 5s))
        << sh("ps -ef").out;
  }
  void TearDown() override {
    if (pid_ > 0) {
      ::kill(pid_, SIGINT);
      end();
    }
  }

  test_support::TempDir dir_;
  fs::path config_, log_;
  pid_t pid_ = -1;
  std::string id_;  // what lbpkit linuxcnc names its namespace and link after
  unsigned long linuxCncNs_ = 0;  // LinuxCNC's PID namespace while it ran
  pid_t simPid_ = -1;             // lbpkit linuxcnc's sim
  std::string shmBefore_;  // System V shared memory segments before the test
};

TEST_F(LinuxCncCommand, CtrlCStopsLinuxCncAndTheSimAndRemovesTheNamespace) {
  ASSERT_TRUE(start()) << slurp(log_);
  // LinuxCNC's lock file is in a /tmp of its own: another LinuxCNC on this
  // PC neither finds it nor cleans this one up.
  EXPECT_FALSE(fs::exists("/tmp/linuxcnc.lock"));
  const auto own = runFolder(pid_) / "tmp";
  EXPECT_TRUE(fs::exists(own / "linuxcnc.lock")) << own;
  // rtapi_app's main thread and its servo thread at SCHED_FIFO 30, as on a
  // real-time kernel; its message thread where LinuxCNC puts it, at the
  // normal class (linuxcnc/servo_priority.hpp).
  const auto threads = sh("for p in $(ip netns pids lbpkit-linuxcnc-" + id_ +
                          "); do [ \"$(cat /proc/$p/comm)\" = rtapi_app ] && ps -L -o comm=,cls=,rtprio= -p $p; done").out;
  unsigned fifo = 0;
  std::istringstream lines(threads);
  for (std::string comm, cls, prio; lines >> comm >> cls >> prio;) {
    if (comm == "rtapi_app:mesg") {
      EXPECT_EQ(cls, "TS") << threads;
    } else {
      EXPECT_EQ(cls + " " + prio, "FF 30") << comm << " in\n" << threads;
      ++fifo;
    }
  }
  EXPECT_GE(fifo, 2U) << "the main thread and the servo thread (rtapi_app:T#0):\n" << threads;
  ::kill(pid_, SIGINT);
  EXPECT_EQ(end(), 130) << slurp(log_);
  expectNothingLeft();
  EXPECT_NE(slurp(log_).find("the network namespace is removed"), std::string::npos) << slurp(log_);
}

TEST_F(LinuxCncCommand, AKilledLinuxCncStopsTheSim) {
  ASSERT_TRUE(start()) << slurp(log_);
  // Everything of LinuxCNC's, in its namespace, killed at once.
  auto pids = sh("ip netns pids lbpkit-linuxcnc-" + id_).out;
  std::replace(pids.begin(), pids.end(), '\n', ' ');
  ASSERT_NE(pids.find_first_not_of(' '), std::string::npos);
  sh("kill -9 " + pids);
  EXPECT_NE(end(), -2) << slurp(log_);
  expectNothingLeft();
  EXPECT_NE(slurp(log_).find("LinuxCNC was killed"), std::string::npos) << slurp(log_);
}

TEST_F(LinuxCncCommand, AKilledSimStopsLinuxCnc) {
  ASSERT_TRUE(start()) << slurp(log_);
  ASSERT_EQ(::kill(simPid_, SIGKILL), 0);
  EXPECT_EQ(end(), 1) << slurp(log_);
  expectNothingLeft();
  EXPECT_NE(slurp(log_).find("lbpkit sim ended"), std::string::npos) << slurp(log_);
}

// What a configuration holds is data, never a command: an address that is
// not a unicast IPv4 address (a shell substitution among them) is refused,
// naming the INI's line, before anything is built.
TEST_F(LinuxCncCommand, ABoardAddressThatIsNotAUnicastOneIsRefusedBeforeAnythingIsBuilt) {
  const auto marker = dir_.path() / "PWNED1";
  const auto before = runNamespaces();
  for (const std::string& address : std::vector<std::string>{"$(touch${IFS}" + marker.string() + ")10.77.1.5", std::string("0.0.0.0"),
                                    std::string("127.0.0.1"), std::string("10.77.1.255"),
                                    std::string("255.255.255.255"), std::string("224.0.0.1"), std::string("::1"),
                                    std::string("localhost"), std::string("10.1.2")}) {
    atAddress(address);
    const auto r = runToEnd(config_ / "mill.ini");
    EXPECT_EQ(r.exit, 1) << address << ":\n" << r.out;
    EXPECT_NE(r.out.find("mill.ini:"), std::string::npos) << address << ":\n" << r.out;
    EXPECT_EQ(r.out.find("cannot set up network namespace"), std::string::npos) << address << ":\n" << r.out;
    EXPECT_FALSE(fs::exists(marker)) << address;
  }
  EXPECT_EQ(runNamespaces(), before);
}

// --linuxcnc-root is entered by LinuxCNC's PID 1 as root: a folder another
// user could write to on the way, a path through a link, or a folder
// without LinuxCNC is refused by name before the namespace or the sim is
// made (linuxcnc/linuxcnc_root.hpp).
TEST_F(LinuxCncCommand, ALinuxCncRootAUserCouldPlantIsRefusedBeforeAnythingIsBuilt) {
  const auto before = runNamespaces();
  const auto planted = dir_.path() / "root";
  fs::create_directories(planted / "usr/bin");
  std::ofstream(planted / "usr/bin/linuxcnc") << "#!/bin/sh\ntouch " << (dir_.path() / "PWNED2").string() << "\n";
  fs::permissions(planted / "usr/bin/linuxcnc", fs::perms::owner_all);
  struct Case {
    std::string root, says;
  };
  for (const auto& c : {Case{planted.string(), "is not root's own, or another user may write to it"},
                        Case{"relative/root", "not an absolute path"}, Case{"/usr/share", "no /usr/bin/linuxcnc in it"}}) {
    const auto r = runToEnd(config_ / "mill.ini", {"--linuxcnc-root", c.root});
    EXPECT_EQ(r.exit, 1) << c.root << ":\n" << r.out;
    EXPECT_NE(r.out.find("--linuxcnc-root " + c.root + ": " ), std::string::npos) << r.out;
    EXPECT_NE(r.out.find(c.says), std::string::npos) << r.out;
  }
  EXPECT_FALSE(fs::exists(dir_.path() / "PWNED2"));
  EXPECT_EQ(runNamespaces(), before);
}

// An address this PC already has, or routes through, is refused by name:
// in a network namespace of the test's own, with an address on a link and
// a default route through a gateway beside it (a veth pair stands for the
// LAN).
TEST_F(LinuxCncCommand, AnAddressOfThisPcOrItsGatewayIsRefused) {
  const std::string net = "lbpkit-pc-" + std::to_string(::getpid());
  const std::string lan = "10.79." + std::to_string(::getpid() % 250) + ".";
  // Removed however the test ends, a set-up that failed half-way included.
  struct RemoveNetns {
    std::string name;
    ~RemoveNetns() { sh("ip netns del " + name); }
  } removeNetns{net};
  ASSERT_EQ(sh("ip netns add " + net + " && ip -n " + net + " link set lo up && ip -n " + net +
               " link add lan0 type veth peer name lan1 && ip -n " + net + " addr add " + lan + "2/24 dev lan0 && ip -n " +
               net + " link set lan1 up && ip -n " + net + " link set lan0 up && ip -n " + net + " route add default via " + lan + "1")
                .exit,
            0);
  auto inPc = [&](const std::string& address) {
    atAddress(address);
    return sh("ip netns exec " + net + " " + LBPKIT_BINARY + " linuxcnc " + (config_ / "mill.ini").string());
  };
  const auto gateway = inPc(lan + "1");
  EXPECT_NE(gateway.exit, 0);
  EXPECT_NE(gateway.out.find(lan + "1 is this PC's gateway"), std::string::npos) << gateway.out;
  const auto own = inPc(lan + "2");
  EXPECT_NE(own.exit, 0);
  EXPECT_NE(own.out.find(lan + "2 is this PC's own address (on lan0)"), std::string::npos) << own.out;
  EXPECT_EQ(gateway.out.find("cannot set up network namespace"), std::string::npos) << gateway.out;
}

// A configuration's file name is only a name: one that would be a command
// in a shell is converted by update_ini (an argument, not a command line)
// and runs.
TEST_F(LinuxCncCommand, AConfigurationsFileNameIsNeverACommand) {
  const std::string hostile = "a'$(touch PWNED2)'.ini";
  auto ini = slurp(config_ / "mill.ini");
  // No [EMC]VERSION: a configuration from before LinuxCNC 2.8, converted.
  ini = std::regex_replace(ini, std::regex(R"(^VERSION = .*$)", std::regex::multiline), "");
  std::ofstream(config_ / hostile) << ini;
  ASSERT_TRUE(start({}, config_ / hostile, {"--display", (dir_.path() / "waiting_display").string()})) << slurp(log_);
  const auto text = slurp(log_);
  EXPECT_NE(text.find("converted with update_ini -f"), std::string::npos) << text;
  EXPECT_EQ(text.find("a fault in lbpkit"), std::string::npos) << text;
  ::kill(pid_, SIGINT);
  EXPECT_EQ(end(), 130) << slurp(log_);
  expectNothingLeft();
  EXPECT_EQ(sh("find / -xdev -name PWNED2 2>/dev/null").out, "");
}

// SUDO_UID, SUDO_GID and SUDO_USER that name no account, or disagree, are
// refused before anything is built: no guessing who LinuxCNC runs as, and
// no older run's LinuxCNC log shown.
TEST_F(LinuxCncCommand, SudoVariablesThatNameNoAccountAreRefused) {
  const auto before = runNamespaces();
  std::ofstream(dir_.path() / "linuxcnc_debug.txt") << "AN OLDER RUN'S LOG\n";
  struct Case {
    const char* user;
    const char* uid;
    const char* gid;
    const char* named;
  };
  for (const auto& c : {Case{"nobody", "abc", "65534", "SUDO_UID"}, Case{"nobody", "4000000000", "65534", "SUDO_UID"},
                        Case{"nobody", "3999999", "65534", "SUDO_UID"}, Case{"root", "65534", "65534", "SUDO_USER"},
                        Case{"nobody", "65534", "x", "SUDO_GID"}}) {
    ::setenv("SUDO_USER", c.user, 1);
    ::setenv("SUDO_UID", c.uid, 1);
    ::setenv("SUDO_GID", c.gid, 1);
    const auto r = runToEnd(config_ / "mill.ini");
    EXPECT_EQ(r.exit, 1) << c.uid << ":\n" << r.out;
    EXPECT_NE(r.out.find(c.named), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("OLDER RUN"), std::string::npos) << r.out;
  }
  ::unsetenv("SUDO_USER");
  ::unsetenv("SUDO_UID");
  ::unsetenv("SUDO_GID");
  EXPECT_EQ(runNamespaces(), before);
}

// What another user planted where a run would work, and a link in the
// invoking user's home, are neither followed nor shown: the run's folder is
// new (a folder by the old predictable name, and one by the new pattern,
// both made by nobody, are left as they are), and LinuxCNC's log, a link
// to a root-only file, is not printed when LinuxCNC fails.
TEST_F(LinuxCncCommand, WhatAnotherUserPlantedIsNeitherFollowedNorShown) {
  const auto home = dir_.path() / "home";
  test_support::TemporaryUser user(home);
  const auto secret = dir_.path() / "root-only";
  std::ofstream(secret) << "ROOT-ONLY-BYTES\n";
  fs::permissions(secret, fs::perms::owner_read | fs::perms::owner_write);
  const auto rootFolder = dir_.path() / "root-folder";
  fs::create_directory(rootFolder);
  fs::permissions(rootFolder, fs::perms::owner_all);
  fs::create_symlink(secret, home / "linuxcnc_debug.txt");
  ASSERT_EQ(::lchown((home / "linuxcnc_debug.txt").c_str(), user.uid(), user.gid()), 0);
  displayEndingWith(1);
  // The run, held until its folders are planted.
  int go[2];
  ASSERT_EQ(::pipe(go), 0);
  log_ = dir_.path() / "linuxcnc.log";
  pid_ = ::fork();
  if (pid_ == 0) {
    ::close(go[1]);
    char c;
    (void)!::read(go[0], &c, 1);
    user.asSudoUser();
    execAsAUser();
  }
  ::close(go[0]);
  id_ = std::to_string(pid_);
  const pid_t run = pid_;
  const std::vector<fs::path> planted = {"/tmp/lbpkit-linuxcnc-" + std::to_string(pid_),
                                         "/tmp/lbpkit-linuxcnc-" + std::to_string(pid_) + "-AAAAAA"};
  for (const auto& f : planted) {
    fs::create_directory(f);
    fs::create_symlink(rootFolder, f / "tmp");
    fs::create_symlink(secret, f / "machine.toml");
    fs::create_symlink(secret, f / "machine.toml.part");
    sh("chown -hR nobody: " + f.string());
  }
  (void)!::write(go[1], "g", 1);
  ::close(go[1]);
  const int status = end();
  const auto text = slurp(log_);
  EXPECT_EQ(status, 1) << text;
  EXPECT_NE(text.find("LinuxCNC ended (exit status 1)"), std::string::npos) << text;
  EXPECT_EQ(text.find("ROOT-ONLY"), std::string::npos) << text;
  EXPECT_EQ(slurp(secret), "ROOT-ONLY-BYTES\n");
  EXPECT_EQ(fs::status(rootFolder).permissions(), fs::perms::owner_all);
  EXPECT_TRUE(fs::is_empty(rootFolder));
  for (const auto& f : planted) {
    struct stat st {};
    EXPECT_EQ(::lstat(f.c_str(), &st), 0) << f;
    EXPECT_EQ(st.st_uid, 65534U) << f;
    EXPECT_TRUE(fs::is_symlink(f / "tmp")) << f;
    EXPECT_TRUE(fs::is_symlink(f / "machine.toml.part")) << f;
    fs::remove_all(f);
  }
  EXPECT_EQ(leftOf(run, kCardAddress), "");
}

// A second run on the address of a live one is refused, naming that run;
// the first runs on. Then a SIGKILL of the first: within 10 s nothing of it
// is left (its reaper, PID 1 of the run's PID namespace, kills whatever
// the run started and removes its namespace, link and folder).
TEST_F(LinuxCncCommand, ASecondRunOnALiveRunsAddressIsRefusedAndASigkillLeavesNothing) {
  ASSERT_TRUE(start()) << slurp(log_);
  const auto second = runToEnd(config_ / "mill.ini", {"--", "--state", (dir_.path() / "second.eeprom").string()});
  EXPECT_EQ(second.exit, 1) << second.out;
  EXPECT_NE(second.out.find(std::string(kCardAddress) + " is in use: the card of another lbpkit linuxcnc (pid " + id_),
            std::string::npos)
      << second.out;
  EXPECT_EQ(::kill(pid_, 0), 0);
  EXPECT_GT(processesIn(linuxCncNs_), 0);
  EXPECT_EQ(killedLeaves(linuxCncNs_), "") << sh("ps -ef").out;
}

// A SIGKILL while the run is being set up (its folder made, its namespace
// built, the sim started): within 10 s nothing of it is left.
TEST_F(LinuxCncCommand, ASigkillDuringSetUpLeavesNothing) {
  for (const std::string& moment : std::vector<std::string>{"folder", "namespace", "sim"}) {
    log_ = dir_.path() / ("linuxcnc-" + moment + ".log");
    pid_ = ::fork();
    if (pid_ == 0) execAsAUser();
    const pid_t run = pid_;
    const bool reached = test_support::waitFor(
        [&] {
          if (moment == "folder") return !runFolder(run).empty();
          if (moment == "namespace") return fs::exists("/run/netns/lbpkit-linuxcnc-" + std::to_string(run));
          // The sim started: a child of the run whose command line is `sim`'s.
          std::istringstream children(slurp("/proc/" + std::to_string(run) + "/task/" + std::to_string(run) +
                                            "/children"));
          for (std::string child; children >> child;) {
            const auto cmdline = slurp("/proc/" + child + "/cmdline");
            if (cmdline.find(std::string("sim\0--bind", 11)) != std::string::npos) return true;
          }
          return false;
        },
        30s, 1ms);
    EXPECT_TRUE(reached) << moment << "\n" << slurp(log_);
    EXPECT_EQ(killedLeaves(), "") << moment << "\n" << slurp(log_);
  }
}

// What a run that is gone left (killed where nothing could clean up, or
// by an older lbpkit) is removed by the next run: its namespace, link and
// folder, found by their names, once their owner is gone; a folder of that
// name that is not root's is not taken for a run's.
TEST_F(LinuxCncCommand, WhatADeadRunLeftIsRemovedByTheNext) {
  const pid_t dead = ::fork();
  if (dead == 0) ::_exit(0);
  ::waitpid(dead, nullptr, 0);
  const auto id = std::to_string(dead);
  ASSERT_EQ(sh("ip netns add lbpkit-linuxcnc-" + id + " && ip link add lbl" + id + " type veth peer name lbl" + id +
               "h && ip link set lbl" + id + "h netns lbpkit-linuxcnc-" + id)
                .exit,
            0);
  const fs::path folder = "/tmp/lbpkit-linuxcnc-" + id + "-Dead00";
  const fs::path notRoots = "/tmp/lbpkit-linuxcnc-" + id + "-Other0";
  fs::create_directories(folder / "user");
  std::ofstream(folder / "machine.toml") << "\n";
  fs::create_directory(notRoots);
  sh("chown nobody: " + notRoots.string());
  atAddress("127.0.0.1");  // refused once the dead run's are removed
  const auto r = runToEnd(config_ / "mill.ini");
  EXPECT_EQ(r.exit, 1) << r.out;
  EXPECT_NE(r.out.find("removed network namespace lbpkit-linuxcnc-" + id), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists("/run/netns/lbpkit-linuxcnc-" + id));
  EXPECT_TRUE(test_support::waitFor([&] { return !fs::exists("/sys/class/net/lbl" + id); }, 5s));
  EXPECT_FALSE(fs::exists(folder));
  EXPECT_TRUE(fs::exists(notRoots));
  fs::remove_all(notRoots);
}

// On a PC whose kernel is not real-time (this one, said so in case CI's
// is), the configuration runs as an on-time machine would, and the run
// says what it changed: the sim on LinuxCNC's servo cycles, hm2_eth's wait
// for a reply in a copy's last HAL file.
TEST_F(LinuxCncCommand, OnAPcWithoutARealTimeKernelItRunsAsOnAnOnTimeMachine) {
  ::setenv("LBPKIT_REALTIME", "no", 1);
  const bool up = start();
  ::unsetenv("LBPKIT_REALTIME");
  ASSERT_TRUE(up) << slurp(log_);
  const auto text = slurp(log_);
  EXPECT_NE(text.find("LinuxCNC will not run real-time on this PC (LBPKIT_REALTIME=no)"), std::string::npos) << text;
  EXPECT_NE(text.find("--clock host=1000000, [EMCMOT]SERVO_PERIOD: mill.ini:60"), std::string::npos) << text;
  EXPECT_NE(text.find("one servo period (1 ms) per host cycle"), std::string::npos) << text;
  EXPECT_NE(text.find("hm2_7i92.0.packet-read-timeout 20000000"), std::string::npos) << text;
  EXPECT_NE(text.find("/user/config/mill.ini) in network namespace"), std::string::npos) << text;
  EXPECT_EQ(pin("hm2_7i92.0.packet-read-timeout"), "20000000");
  ::kill(pid_, SIGINT);
  EXPECT_EQ(end(), 130) << slurp(log_);
  expectNothingLeft();
}

// On a real-time PC (the detection told so) the configuration runs as
// written, and the sim on the wall clock, as the real card will.
TEST_F(LinuxCncCommand, OnARealTimePcItRunsAsWritten) {
  ::setenv("LBPKIT_REALTIME", "yes", 1);
  const bool up = start();
  ::unsetenv("LBPKIT_REALTIME");
  ASSERT_TRUE(up) << slurp(log_);
  const auto text = slurp(log_);
  EXPECT_NE(text.find("LinuxCNC runs real-time on this PC (LBPKIT_REALTIME=yes): the configuration runs as written"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("time: follows the wall clock"), std::string::npos) << text;
  EXPECT_NE(text.find("LinuxCNC (" + (config_ / "mill.ini").string() + ") in network namespace"), std::string::npos)
      << text;
  EXPECT_EQ(text.find("packet-read-timeout"), std::string::npos) << text;
  EXPECT_EQ(pin("hm2_7i92.0.packet-read-timeout"), "80");  // hm2_eth's own: 80 % of a period
  ::kill(pid_, SIGINT);
  EXPECT_EQ(end(), 130) << slurp(log_);
  expectNothingLeft();
}

// When LinuxCNC stops with an error, what it printed is printed: here its
// display's words on standard output and standard error, before it ended.
TEST_F(LinuxCncCommand, WhenLinuxCncFailsWhatItPrintedIsShown) {
  displayFailing();
  log_ = dir_.path() / "linuxcnc.log";
  pid_ = ::fork();
  if (pid_ == 0) execAsAUser();
  id_ = std::to_string(pid_);
  EXPECT_EQ(end(), 3);
  const auto text = slurp(log_);
  EXPECT_NE(text.find("LinuxCNC ended (exit status 3)"), std::string::npos) << text;
  EXPECT_NE(text.find("  | the display: no tool table here"), std::string::npos) << text;
  EXPECT_NE(text.find("  | the display: giving up"), std::string::npos) << text;
  EXPECT_EQ(leftOf(std::stoi(id_), kCardAddress), "");
}

// The real AXIS on an X server of its own (Xvfb), the example mill's
// configuration as it is: AXIS's own keys take the machine out of E-stop
// (F1), turn it on (F2) and home all joints (Ctrl-Home), as an operator
// does; HAL says every joint is homed, and a screenshot of AXIS is kept in
// the build folder (screenshots/axis-mill-homed.png).
class AxisGui : public LinuxCncCommand {
 protected:
  void SetUp() override {
    LinuxCncCommand::SetUp();
    if (IsSkipped()) return;
    for (const char* tool : {"Xvfb", "xdotool", "import", "nsenter"})
      if (!have(tool)) GTEST_SKIP() << tool << " is not installed (xvfb, xdotool, imagemagick, util-linux)";
    // The configuration as published (its display is AXIS), but for the
    // card's address.
    fs::copy_file(fs::path(LBPKIT_SOURCE_DIR) / "examples/linuxcnc/mill/mill.ini", config_ / "mill.ini",
                  fs::copy_options::overwrite_existing);
    atAddressOfItsOwn();
    ASSERT_TRUE(desktop_.up()) << "Xvfb did not start";
    display_ = desktop_.display();
    ASSERT_TRUE(test_support::waitFor([&] { return x("xdotool getdisplaygeometry").exit == 0; }, 10s))
        << "Xvfb " << display_ << " did not start";
  }
  // A command on the X display.
  interop::Shell x(const std::string& command) { return sh("DISPLAY=" + display_ + " " + command); }

  test_support::Xvfb desktop_;
  std::string display_;
};

// On a desktop, LinuxCNC that fails shows what it printed in a window of its
// own and waits there (the linuxcnc script's show_errors.tcl): the terminal
// the command was typed in says so, with LinuxCNC's words, while the window
// waits; closing it ends the run with LinuxCNC's status, nothing left.
TEST_F(AxisGui, LinuxCncsErrorWindowIsNamedWhereTheCommandWasTyped) {
  displayFailing();
  log_ = dir_.path() / "linuxcnc.log";
  pid_ = ::fork();
  if (pid_ == 0) {
    ::setenv("DISPLAY", display_.c_str(), 1);
    execAsAUser();
  }
  id_ = std::to_string(pid_);
  ASSERT_TRUE(test_support::waitFor(
      [&] {
        const auto text = slurp(log_);
        return text.find("  | the display: giving up") != std::string::npos;
      },
      60s, 250ms))
      << slurp(log_);
  const auto text = slurp(log_);
  EXPECT_NE(text.find("LinuxCNC ended with an error; its window \"LinuxCNC Errors\" waits on the desktop"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("  | the display: no tool table here"), std::string::npos) << text;
  // The window is there, and the run waits for it.
  const auto window = x("xdotool search --name '^LinuxCNC Errors$'").out;
  ASSERT_FALSE(window.empty()) << sh("ps -ef").out;
  EXPECT_TRUE(::kill(pid_, 0) == 0 && ::waitpid(pid_, nullptr, WNOHANG) == 0);
  // Closed, as its Close button does.
  EXPECT_EQ(x("xdotool windowclose " + window.substr(0, window.find('\n'))).exit, 0);
  EXPECT_EQ(end(), 3) << slurp(log_);
  EXPECT_EQ(leftOf(std::stoi(id_), kCardAddress), "");
}

TEST_F(AxisGui, AxisHomesTheMillThroughItsOwnControls) {
  ASSERT_TRUE(start(display_)) << slurp(log_);
  // AXIS's main window: "mill.ini - AXIS <version> on lbpkit-mill"
  // ([EMC]MACHINE), once AXIS has loaded the configuration.
  std::string window;
  ASSERT_TRUE(test_support::waitFor(
      [&] {
        window = x("xdotool search --onlyvisible --name ' - AXIS .* on '").out;
        return !window.empty();
      },
      60s, 250ms))
      << slurp(log_);
  window = window.substr(0, window.find('\n'));
  // AXIS takes keys once its HAL component is ready (its setup done).
  ASSERT_TRUE(test_support::waitFor([&] { return pin("axisui.error") == "FALSE" || pin("axisui.abort") == "FALSE"; },
                                    30s, 250ms))
      << sh("ip netns pids lbpkit-linuxcnc-" + id_).out << slurp(log_);
  ASSERT_EQ(x("xdotool windowfocus --sync " + window).exit, 0);
  // One key press each, as an operator's: F1 E-stop off, F2 machine on.
  auto press = [&](const std::string& key, const std::string& pinName, const std::string& value) {
    x("xdotool key " + key);
    return test_support::waitFor([&] { return pin(pinName) == value; }, 10s, 100ms);
  };
  ASSERT_TRUE(press("F1", "halui.estop.is-activated", "FALSE")) << "AXIS's F1: still in E-stop\n" << slurp(log_);
  ASSERT_TRUE(press("F2", "halui.machine.is-on", "TRUE")) << "AXIS's F2: the machine is not on\n" << slurp(log_);
  x("xdotool key ctrl+Home");
  const bool homed = test_support::waitFor(
      [&] { return pin("joint.0.homed") == "TRUE" && pin("joint.1.homed") == "TRUE" && pin("joint.2.homed") == "TRUE"; },
      60s, 250ms);
  // What AXIS shows, kept whatever the outcome.
  const fs::path shots = LBPKIT_SCREENSHOT_DIR;
  fs::create_directories(shots);
  const auto shot = shots / "axis-mill-homed.png";
  std::this_thread::sleep_for(1s);  // AXIS redraws its DRO and homed marks every 100 ms or so
  EXPECT_EQ(x("import -window root " + shot.string()).exit, 0);
  EXPECT_GT(fs::exists(shot) ? fs::file_size(shot) : 0, 10'000U);
  std::printf("AXIS screenshot: %s\n", shot.c_str());
  EXPECT_TRUE(homed) << "joints homed: " << pin("joint.0.homed") << " " << pin("joint.1.homed") << " "
                     << pin("joint.2.homed") << "\n" << slurp(log_);
  // Homed where the mill's configuration puts home, each joint's feedback
  // within one count (1/1000 mm) of its command.
  for (int j = 0; j < 3; ++j) {
    const auto n = "joint." + std::to_string(j);
    const double cmd = std::atof(pin(n + ".motor-pos-cmd").c_str());
    const double fb = std::atof(pin(n + ".motor-pos-fb").c_str());
    EXPECT_NEAR(fb, cmd, 0.0011) << n;
  }
  ::kill(pid_, SIGINT);
  EXPECT_EQ(end(), 130) << slurp(log_);
  expectNothingLeft();
}

}  // namespace
