// SPDX-License-Identifier: MIT
// `lbpkit bench`: the performance figures, measured on the machine
// at hand, each beside what it is compared against in the same run. What the
// parts share: the options, and the processes they start (sims, LinuxCNC in
// a network namespace, CPU hogs), each stopped by its owner's destructor on
// every way out, Ctrl-C included (lbpkit::app::gStop, checked by every wait).
#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace lbpkit::app::bench {

struct Options {
  double seconds = 10;  // per measured point (the in-process part: simulated seconds)
  std::vector<unsigned> rates{1000, 2000, 4000, 10000};  // LinuxCNC servo thread, Hz
  std::vector<unsigned> boards{1, 10, 50};                // sims side by side
  // The CPU wake-up latency of the rows where the sim holds it
  // (`lbpkit sim --cpu-latency`), replies and network at 1 kHz; -1 leaves them out.
  int cpuLatencyUs = 0;
  bool json = false;
};

// Ctrl-C (or SIGTERM) arrived: the part stops, its destructors clean up.
void checkStop();
// Sleeps `d`, waking early (and throwing) on Ctrl-C.
void sleepFor(std::chrono::duration<double> d);

// A program's exit status and output. The bench starts every program by an
// argument vector found in the system's folders, never through a shell or a
// PATH (docs/linuxcnc.md#what-runs-as-root): `sudo lbpkit bench` runs as root.
struct Run {
  int exit = -1;  // -1 when it could not start or was killed
  std::string out;
};
// Runs argv (argv[0] a name lbpkit::process::systemProgram finds, or an
// absolute path) with stdin from /dev/null, and waits for it. Its output is
// collected through a file in scratch(), not a pipe: rtapi_app, which the
// first halcmd starts, keeps halcmd's output open long after halcmd exits.
Run run(const std::vector<std::string>& argv);
// `name`'s absolute path in the system's folders; throws lbpkit::Error
// saying it is not installed.
std::string installed(const std::string& name);

// The bench's scratch folder (sims' EEPROM files, HAL files), removed at exit.
const std::filesystem::path& scratch();

// `lbpkit sim --bind ADDRESS --api 0` started from this very binary, stopped
// (SIGTERM, then SIGKILL) by the destructor.
class SimProcess {
 public:
  explicit SimProcess(const std::string& address, std::vector<std::string> extra = {})
      : SimProcess(std::vector<std::string>{address}, std::move(extra)) {}
  // One process serving a card on each address (`lbpkit sim --bind A
  // --bind B ...`); address() and state() are the first card's.
  SimProcess(std::vector<std::string> addresses, std::vector<std::string> extra);
  ~SimProcess();
  SimProcess(const SimProcess&) = delete;
  SimProcess& operator=(const SimProcess&) = delete;
  // GET /api/state; null when the sim does not answer.
  [[nodiscard]] nlohmann::json state() const;
  [[nodiscard]] pid_t pid() const { return pid_; }
  [[nodiscard]] const std::string& address() const { return addresses_.front(); }
  [[nodiscard]] const std::vector<std::string>& addresses() const { return addresses_; }

 private:
  std::vector<std::string> addresses_;
  std::filesystem::path stateFile_;
  pid_t pid_ = -1;
  int out_ = -1;
  int apiPort_ = 0;
};

// One spinning process per CPU this process may run on, at normal priority:
// what a compile or a GUI does to a commissioning laptop. Killed by the
// destructor.
class CpuHog {
 public:
  CpuHog();
  ~CpuHog();
  CpuHog(const CpuHog&) = delete;
  CpuHog& operator=(const CpuHog&) = delete;
  [[nodiscard]] unsigned processes() const { return static_cast<unsigned>(pids_.size()); }

 private:
  std::vector<pid_t> pids_;
};

// A process's CPU time so far (user + system, /proc/PID/stat), seconds.
double cpuSeconds(pid_t pid);
// The CPU time processes take from its construction on, beside the wall
// time that passes.
class CpuMeter {
 public:
  explicit CpuMeter(std::vector<pid_t> pids);
  [[nodiscard]] double seconds() const;  // all of theirs since construction
  [[nodiscard]] double wall() const;     // since construction
  // seconds() as a share of wall(), in % of one CPU.
  [[nodiscard]] double percent() const;

 private:
  std::vector<pid_t> pids_;
  double start_ = 0;
  std::chrono::steady_clock::time_point t0_;
};
// Its memory, kB: resident (VmRSS) and proportional (Pss: shared pages split
// among their users, so N sims add up to what they really take).
struct Memory {
  long rssKb = -1;
  long pssKb = -1;
};
Memory memory(pid_t pid);
// This machine: CPU model, cores, kernel, load average.
nlohmann::json machine();
double loadAverage();

// Stops a child process: SIGTERM, up to 3 s to go, then SIGKILL; reaped.
void stopProcess(pid_t pid);
// A part's "skipped" line, when it has one (and then true: nothing else to print).
bool printedSkip(const nlohmann::json& j);

// The parts: each returns its figures as JSON ({"skipped": why} when it
// cannot run here) and prints them as text when not --json.
nlohmann::json runInProcess(const Options& o);
nlohmann::json runNetwork(const Options& o);
nlohmann::json runDiscovery(const Options& o);
nlohmann::json runBoards(const Options& o);
nlohmann::json runReplies(const Options& o);
void printInProcess(const nlohmann::json& j);
void printNetwork(const nlohmann::json& j);
void printDiscovery(const nlohmann::json& j);
void printBoards(const nlohmann::json& j);
void printReplies(const nlohmann::json& j);

}  // namespace lbpkit::app::bench
