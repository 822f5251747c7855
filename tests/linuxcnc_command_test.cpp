// `lbpkit linuxcnc CONFIG.ini` on the example mill (examples/linuxcnc/mill),
// its display a script that only waits: LinuxCNC comes up against the sim at
// the configuration's board_ip (its servo thread's DOITs reach the sim), and
// every way out (Ctrl-C, LinuxCNC killed, the sim killed) leaves no network
// namespace, no veth and no process behind. Needs root and linuxcnc-uspace
// (scripts/test installs it).
#include <fcntl.h>
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
#include "support/wait.hpp"

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
  void atAddressOfItsOwn() {
    const auto ini = slurp(config_ / "mill.ini");
    std::ofstream(config_ / "mill.ini")
        << std::regex_replace(ini, std::regex(R"(^IPADDRESS = 10\.10\.10\.10$)", std::regex::multiline),
                              "IPADDRESS = " + std::string(kCardAddress));
  }

  // lbpkit linuxcnc started, its output in a file; true once LinuxCNC's
  // servo thread runs the card (the sim has counted DOITs). `display`: the X
  // display LinuxCNC's own display program shows on (DISPLAY), or none.
  bool start(const std::string& display = {}) {
    log_ = dir_.path() / "linuxcnc.log";
    pid_ = ::fork();
    id_ = std::to_string(pid_ % 100000);
    if (pid_ == 0) {
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
      const std::string ini = (config_ / "mill.ini").string();
      const std::string state = (dir_.path() / "sim.eeprom").string();
      // On the sim's host clock (docs/clocks.md): a servo thread held back
      // here still finds each DoIt done, and hostmot2 keeps the smart-serial
      // port running.
      // On the CPU before the last (tests/CMakeLists.txt locks it): one
      // LinuxCNC a CPU beside the other end-to-end runs.
      const auto cpu = std::to_string(test_support::cardCpu(1));
      ::execl(LBPKIT_BINARY, LBPKIT_BINARY, "linuxcnc", ini.c_str(), "--machine", "mill", "--cpu", cpu.c_str(), "--",
              "--state", state.c_str(), "--clock", "host=1ms", static_cast<char*>(nullptr));
      ::_exit(127);
    }
    std::string url;
    const bool up = test_support::waitFor(
        [&] {
          // lbpkit linuxcnc ended before LinuxCNC ran: nothing more to wait
          // for (its log says why).
          int status = 0;
          if (::waitpid(pid_, &status, WNOHANG) == pid_) {
            pid_ = -1;
            return true;
          }
          std::smatch m;
          const auto text = slurp(log_);
          if (std::regex_search(text, m, std::regex(R"(web view: (http://127\.0\.0\.1:\d+)/)"))) url = m[1];
          // Past hm2_eth's discovery (about 1300 DOITs): its servo thread runs.
          return !url.empty() && doits(url) > 3000;
        },
        60s, 200ms);
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
  const auto own = fs::path("/tmp/lbpkit-linuxcnc-" + id_) / "tmp";
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
    // A display number no X server on this PC uses.
    for (int n = 90; n < 190 && display_.empty(); ++n)
      if (!fs::exists("/tmp/.X11-unix/X" + std::to_string(n)) && !fs::exists("/tmp/.X" + std::to_string(n) + "-lock"))
        display_ = ":" + std::to_string(n);
    ASSERT_FALSE(display_.empty());
    xvfb_ = ::fork();
    if (xvfb_ == 0) {
      const int null = ::open("/dev/null", O_WRONLY);
      ::dup2(null, 1);
      ::dup2(null, 2);
      ::execlp("Xvfb", "Xvfb", display_.c_str(), "-screen", "0", "1024x768x24", "-nolisten", "tcp",
               static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ASSERT_TRUE(test_support::waitFor([&] { return x("xdotool getdisplaygeometry").exit == 0; }, 10s))
        << "Xvfb " << display_ << " did not start";
  }
  void TearDown() override {
    LinuxCncCommand::TearDown();
    if (xvfb_ > 0) {
      ::kill(xvfb_, SIGTERM);
      ::waitpid(xvfb_, nullptr, 0);
    }
  }
  // A command on the X display.
  interop::Shell x(const std::string& command) { return sh("DISPLAY=" + display_ + " " + command); }
  // A HAL pin's value in the running LinuxCNC (halcmd in its namespaces).
  std::string pin(const std::string& name) {
    const auto pids = sh("ip netns pids lbpkit-linuxcnc-" + id_).out;
    const auto first = pids.substr(0, pids.find('\n'));
    if (first.empty()) return {};
    auto value = sh("nsenter -t " + first + " -i -m -n halcmd -s getp " + name).out;
    while (!value.empty() && (value.back() == '\n' || value.back() == ' ')) value.pop_back();
    return value;
  }

  std::string display_;
  pid_t xvfb_ = -1;
};

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
