// SPDX-License-Identifier: MIT
// What the tests of the real clients (tests/interop/: mesaflash, LinuxCNC's
// hm2_eth, halcmd beside `lbpkit pins`) share: a shell command's output,
// `lbpkit sim` as a user runs it, and LinuxCNC in a network namespace of
// the test's own joined to the sim's by a veth pair.
#pragma once

#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iterator>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "linuxcnc/network_namespace.hpp"
#include "support/card_cpu.hpp"
#include "support/linuxcnc_release.hpp"
#include "support/process.hpp"
#include "support/sim_child.hpp"
#include "support/wait.hpp"

namespace interop {

using nlohmann::json;
using test_support::Daemon;

struct Shell {
  int exit = -1;
  std::string out;
};

// Runs a shell command; its output goes through a file, not a pipe, since
// what it starts (rtapi_app) may keep its output open long after it exits.
inline Shell sh(const std::string& command) {
  static int serial = 0;
  const auto file = std::filesystem::temp_directory_path() /
                    ("lbpkit-sh-" + std::to_string(::getpid()) + "-" + std::to_string(serial++));
  Shell r;
  const int status = std::system((command + " > " + file.string() + " 2>&1 < /dev/null").c_str());
  r.exit = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(file);
  r.out.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  std::filesystem::remove(file);
  return r;
}

template <typename... A>
std::string fmt(const char* f, A... a) {
  char buf[128];
  std::snprintf(buf, sizeof buf, f, a...);
  return buf;
}

// A program in the system's folders (process/process.hpp).
inline bool have(const char* tool) { return lbpkit::process::systemProgram(tool).has_value(); }

inline void reapOrphans() {
  while (::waitpid(-1, nullptr, WNOHANG) > 0) {
  }
}

// A real client's command prefix: on the card thread's CPU
// (support/card_cpu.hpp).
inline std::string onCardCpu() { return test_support::onCpu(test_support::cardCpu()); }

using test_support::withCardCpu;

// `lbpkit sim` on ADDRESS, on the port hm2_eth and mesaflash use, at the
// priority a user runs it (no --no-realtime), its card thread on the
// clients' CPU (onCardCpu), with its control API on a free port of
// 127.0.0.1 and its state in a folder of its own.
class Sim : public test_support::SimChild {
 public:
  explicit Sim(const std::string& address, std::vector<std::string> extra = {})
      : SimChild(test_support::SimOptions{address, -1, "127.0.0.1", false, {}, withCardCpu(std::move(extra))}) {}
  // POST: the JSON answer, whatever its status.
  json post(const std::string& path, const json& body) { return SimChild::post(path, body).body; }
};

// Not faster than every 25 ms: each look may ask the sim for its whole state
// or start halcmd (five programs through ip netns exec), and on two cores
// that takes CPU from the sim and from LinuxCNC's servo thread.
template <typename F>
bool waitFor(F&& ok, std::chrono::milliseconds limit) {
  return test_support::waitFor(std::forward<F>(ok), limit, std::chrono::milliseconds(25));
}

// A loopback address of this test's own (several cards can run side by side).
inline std::string loopback() { return "127.77." + std::to_string(::getpid() % 200) + ".1"; }

// LinuxCNC's hm2_eth in a network namespace joined by a veth pair to the
// namespace `lbpkit sim` answers in (Debian's hm2_eth cannot use loopback).
// hm2_eth gives the card little time at set-up: a few milliseconds for the
// MAC address (else "rtapi_app_main: Resource temporarily unavailable"), 51
// ms for each smart-serial DoIt of the discovery (else "hm2_sserial_waitfor:
// Timeout"); the sim's card thread answers within microseconds at SCHED_FIFO
// (it runs as root here), and the interop tests run one at a time
// (RUN_SERIAL), so nothing else takes the CPU from it. `hal` runs halcmd in
// the test's namespace.
// hm2_eth counts a reply that has not come 80 % of a servo period after its
// read as a packet error, and ten in a row set io_error; the HostMot2
// watchdog bites when no write has come for 5 ms (hostmot2(9): timeout_ns).
// On this kernel LinuxCNC's servo thread is not real-time, and one held back
// past those moments finds its deadline gone before it looks for the reply
// the card sent in microseconds, or finds the watchdog bitten though the card
// did what it should: LinuxCNC's own scheduling. The tests of names, values
// and watchdogs let it wait 20 ms for a reply (packet-read-timeout, in
// nanoseconds: hm2_eth(9)) and give the watchdog 200 ms, as a configuration
// for such a machine would; the measurements keep hm2_eth's own timeout and
// print what it counts.
inline std::string patientDeadlines(const std::string& board) {
  return "setp " + board + ".packet-read-timeout 20000000\n" + "setp " + board + ".watchdog.timeout_ns 200000000\n";
}

// The 7I77's own watchdog (50 ms, manual: WATCHDOG AND FAULTS) bites when
// its processor hears nothing from the host for that long, and LinuxCNC's
// hostmot2 does not start the port again: outputs stay off. On the sim's
// host clock a host silent past 40 ms of wall clock has stopped, unless the
// sim sees its process runnable, kept from its CPU (docs/clocks.md); a
// servo thread held back 50 ms otherwise (asleep in a system call, or a
// process the sim cannot look into) lets it bite, LinuxCNC's lateness and
// not the card's. The tests that drive outputs and are not about that watchdog give
// each processor's working WATCHDOGTIME 500 ms through LBP before LinuxCNC
// loads (hostmot2 leaves it as it is), as the HostMot2 watchdog gets 200 ms
// in patientDeadlines (test_support::kPatient7i77WatchdogMs).

class LinuxCnc : public ::testing::Test {
 protected:
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "network namespaces need root";
    if (!test_support::haveClientProgram("halcmd") || !have("ip")) GTEST_SKIP() << "linuxcnc-uspace or iproute2 is not installed (scripts/test installs them)";
    ::prctl(PR_SET_CHILD_SUBREAPER, 1);  // rtapi_app outlives halcmd: reap it ourselves
    const auto id = std::to_string(::getpid() % 100000);
    const auto net = "10.211." + std::to_string(::getpid() % 250) + ".";
    cardIp_ = net + "1";
    fifo_ = "/tmp/lbpkit-rtapi-" + id;
    cardLink_ = "lbk" + id;
    try {
      ns_ = std::make_unique<lbpkit::linuxcnc::NetworkNamespace>(
          "lbpkit-" + id, std::vector<lbpkit::linuxcnc::VethLink>{{cardLink_, cardIp_ + "/24", net + "2/24", {}}});
    } catch (const std::exception& e) {
      FAIL() << e.what();
    }
  }
  void TearDown() override {
    if (!ns_) return;
    // A failed run says how late the sim was (its own figures, from each
    // datagram's kernel receive time) and how it was scheduled, beside what
    // hm2_eth counted: whose lateness it was.
    if (HasFailure() && sim_)
      std::printf("sim server: %s\nhm2_eth: packet-error-total %s, io_error %s\n", sim_->get()["server"].dump().c_str(),
                  getp("hm2_7i92.0.packet-error-total").c_str(), getp("hm2_7i92.0.io_error").c_str());
    hal("halrun -U");
    sim_.reset();
    ns_.reset();
    std::filesystem::remove(fifo_);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    reapOrphans();
  }
  // rtapi_app (LinuxCNC's servo thread, hm2_eth's sender) is started by the
  // first halcmd and inherits its scheduling: HAL commands run at SCHED_FIFO
  // priority 1 (below the sim's card thread, 40), as a real-time kernel
  // would run LinuxCNC. hm2_eth's set-up gives each queued read 1.6 ms
  // before its HAL parameters exist (LinuxCNC: hm2_eth.c), and a rtapi_app
  // held back by other work past that deadline fails to load ("rtapi_app_main:
  // Resource temporarily unavailable") though the card answered at once.
  // Commands to a HAL already running pass `nice` instead (halcmd below).
  Shell hal(const std::string& command, const char* nice = "") {
    const std::string priority = *nice != '\0' ? std::string(nice) : "chrt -f 1 " + onCardCpu();
    return sh(priority + ns_->exec() + test_support::inLinuxCncRoot() + lbpkit::linuxcnc::rtapiEnvironment(fifo_) +
              "timeout 60 " + command);
  }
  // `halcmd ARGS` to the HAL rtapi_app already runs (setp, getp, show,
  // stop, start) at nice 10: it needs no real-time priority, and yields the
  // CPU to the sim, which must answer within 0.8 ms, and to LinuxCNC's
  // servo thread.
  Shell halcmd(const std::string& args) { return hal("halcmd " + args, "nice -n 10 "); }
  // The polls (every 25 ms).
  std::string getp(const std::string& pin) {
    auto v = halcmd("getp " + pin).out;
    while (!v.empty() && (v.back() == '\n' || v.back() == ' ')) v.pop_back();
    return v;
  }
  // kPatient7i77WatchdogMs (or `ms`) for the processors on these
  // smart-serial channels (0: the first 7I77's field I/O, 1: its analog
  // side).
  void patient7i77Watchdogs(std::initializer_list<unsigned> channels,
                            const char* ms = test_support::kPatient7i77WatchdogMs) {
    ASSERT_EQ(test_support::patient7i77Watchdogs(cardIp_, channels, ms), "");
  }
  // Loads hostmot2 and hm2_eth with `config`, `board`'s read and write in a
  // 1 kHz servo thread, hm2_eth waiting up to patientDeadlines for each
  // reply.
  Shell loadBoard(const std::string& board, const std::string& config) {
    const auto file = fifo_ + ".hal";
    std::ofstream(file) << "loadrt hostmot2\nloadrt hm2_eth board_ip=" << cardIp_ << " config=\"" << config << "\"\n"
                        << patientDeadlines(board) << "loadrt threads name1=servo period1=1000000\n"
                        << "addf " << board << ".read servo\naddf " << board << ".write servo\nstart\n";
    auto r = hal("halcmd -f " + file);
    std::filesystem::remove(file);
    return r;
  }
  // A copy of a corpus HAL file (board_ip=10.10.10.10) pointed at the sim:
  // its path, `name` telling it apart.
  std::string ownCopy(const std::filesystem::path& file, const std::string& name) {
    std::ifstream in(file);
    std::ostringstream text;
    for (std::string l; std::getline(in, l);) {
      const auto at = l.find("board_ip=10.10.10.10");
      text << (at == std::string::npos ? l : l.replace(at, 20, "board_ip=" + cardIp_)) << "\n";
    }
    const auto own = fifo_ + "-" + name + ".hal";
    std::ofstream(own) << text.str();
    return own;
  }
  // Loads hostmot2 + hm2_eth with the servo thread running; `patient`:
  // hm2_eth waits up to patientDeadlines for each reply (else its own
  // 80 % of the period, which the measurements count against).
  // `messages`: a file that collects rtapi_app's messages (hostmot2's and
  // hm2_eth's complaints) while it runs, else they go with halcmd's output;
  // `extraHal`: HAL commands of the test's own before the thread starts.
  Shell load(const std::string& sserialPort, bool patient = true, const std::string& messages = "",
             const std::string& extraHal = "") {
    const auto file = fifo_ + ".hal";
    std::ofstream(file) << "loadrt hostmot2\n"
                        << "loadrt hm2_eth board_ip=" << cardIp_ << " config=\"num_encoders=6 sserial_port_0="
                        << sserialPort << "\"\n"
                        << (patient ? patientDeadlines("hm2_7i92.0") : "") << "loadrt threads name1=servo period1=1000000\n"
                        << "addf hm2_7i92.0.read servo\n" << extraHal << "addf hm2_7i92.0.write servo\nstart\n";
    auto r = hal(messages.empty() ? "halcmd -f " + file : "sh -c 'exec halcmd -f " + file + " >>" + messages + " 2>&1'");
    std::filesystem::remove(file);
    return r;
  }
  // For the measurements: hm2_eth on its own read timeout. Its set-up gives
  // each queued read 1.6 ms, so on the wall clock of a busy machine it may
  // not load at all; that is printed as what was measured, not failed on.
  bool measuredLoad() {
    const auto r = load("00xxxxxx", false);
    if (r.exit != 0) std::printf("hm2_eth did not load on its own read timeout this time:\n%s\n", r.out.c_str());
    return r.exit == 0;
  }
  // The card for hm2_eth's 1 kHz servo thread, on the sim's host clock
  // (`--clock host=1ms`, docs/clocks.md): each servo cycle's DoIt moves the
  // card one period on, so the next cycle finds it done however late the
  // thread ran (a thread held back runs its late periods back to back, tens
  // of microseconds apart, and on the wall clock hostmot2 stops the
  // smart-serial port after four DoIts not done in time: LinuxCNC's
  // sserial.c). `hostClock` false: the wall clock, for the measurements.
  std::unique_ptr<Sim> cardSim(std::vector<std::string> extra = {}, bool hostClock = true) {
    if (hostClock) extra.insert(extra.end(), {"--clock", "host=1ms"});
    return std::make_unique<Sim>(cardIp_, std::move(extra));
  }
  void startSim(bool hostClock = true) {
    sim_ = cardSim({}, hostClock);
    ASSERT_TRUE(sim_->up());
  }

  std::unique_ptr<lbpkit::linuxcnc::NetworkNamespace> ns_;
  std::string cardIp_, cardLink_, fifo_;  // cardLink_: the veth on the sim's side
  std::unique_ptr<Sim> sim_;
};

}  // namespace interop
