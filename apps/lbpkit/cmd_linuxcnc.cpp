// SPDX-License-Identifier: MIT
// lbpkit linuxcnc CONFIG.ini: a user's own LinuxCNC configuration against
// `lbpkit sim`, in one command (docs/linuxcnc.md#your-configuration-in-one-command).
//
// Debian 12's hm2_eth cannot use a board on loopback, so LinuxCNC runs in a
// network namespace of its own (lbpkit_linuxcnc's NetworkNamespace) joined
// by a veth pair to this PC's, where the sim answers at the configuration's
// own board_ip. LinuxCNC runs in PID, IPC and mount namespaces as well, so
// that whatever it starts (rtapi_app, the display, halcmd) and its shared
// memory end with it and its /tmp is its own; as the user who ran sudo
// (SUDO_UID), with that user's home and DISPLAY, or as nobody (RTAPI_UID)
// when root ran it; its servo thread SCHED_FIFO, as on a real-time kernel.
//
// What runs as root is kept to sudo's rules (docs/linuxcnc.md#what-runs-as-root):
// the configuration is read, checked, derived and copied by a child that
// runs as the user; every program is started by an argument vector; the
// run's folder is new (mkdtemp) and its files are made through its
// descriptor; everything the run starts is in a PID namespace whose PID 1
// is a reaper of lbpkit's (linuxcnc_run.hpp), so that on every way out,
// SIGKILL included, every process, the namespace, the link and the folder
// go.
#include <fcntl.h>
#include <poll.h>
#include <pwd.h>
#include <sched.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "common.hpp"
#include "hostmot2/cards/catalogue.hpp"
#include "lbpkit/error.hpp"
#include "linuxcnc/board_address.hpp"
#include "linuxcnc/config_check.hpp"
#include "linuxcnc/hal_config.hpp"
#include "linuxcnc/hal_name.hpp"
#include "linuxcnc/linuxcnc_root.hpp"
#include "linuxcnc/namespace_processes.hpp"
#include "linuxcnc/network_namespace.hpp"
#include "linuxcnc/servo_priority.hpp"
#include "linuxcnc_host.hpp"
#include "linuxcnc_run.hpp"
#include "process/process.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;
namespace hm2 = lbpkit::model::hm2;

namespace lbpkit::app {
extern std::function<int()> gRun;
}

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

struct LinuxCncOptions {
  std::string ini;
  std::string machine = "auto";
  std::string card;
  std::string display;  // in place of the INI's [DISPLAY]DISPLAY
  std::string cpu = "last";  // --cpu N|last|any: LinuxCNC's and the card thread's CPU
  std::string linuxcncRoot;  // --linuxcnc-root: another Debian release's LinuxCNC (linuxcnc/linuxcnc_root.hpp)
  int readyFd = -1;          // --ready-fd N: the run's greeting, once LinuxCNC starts
  std::vector<std::string> simArguments;  // after --
  bool asWritten = false;  // --as-written: untouched, on the wall clock, on any PC
  bool lateServo = false;  // found at the start: LinuxCNC will not run real-time here, and no --as-written
};

// This process (and whatever it starts) on `cpu` alone, when given.
void pinTo(std::optional<unsigned> cpu) {
  if (cpu) lbpkit::process::pinToCpu(*cpu);
}

// A child process: argv run with stdout and stderr into `out` (a pipe's
// write end) or inherited (-1), `ready` (a pipe's write end, or -1) as its
// descriptor 3, on `cpu` alone when given (and whatever it starts with it),
// in the run's PID namespace. In a process group of its own, so that a
// terminal's Ctrl-C reaches only lbpkit, which stops it in order; it gets
// SIGTERM should lbpkit be killed outright.
pid_t spawn(const std::vector<std::string>& argv, int out, int ready = -1, std::optional<unsigned> cpu = {}) {
  lbpkit::process::SpawnOptions o;
  o.out = out;
  o.ready = ready;
  o.cpu = cpu;
  o.ownProcessGroup = true;
  o.deathSignal = SIGTERM;
  o.nullStdin = false;
  o.fork = &app::linuxcnc_run::forkInRun;
  try {
    return lbpkit::process::spawn(argv, o);
  } catch (const std::runtime_error& e) {
    throw lbpkit::Error(e.what());
  }
}

// Stops a child (SIGTERM, then SIGKILL to it and its process group after
// `grace`) and reaps it: its exit status, or -1.
int stop(pid_t pid, std::chrono::milliseconds grace) {
  const int status = lbpkit::process::stopWithGrace(pid, grace, SIGTERM, true);
  return status >= 128 ? -1 : status;
}

// A descriptor of the run's, closed when destroyed.
class OwnedFd {
 public:
  OwnedFd() = default;
  explicit OwnedFd(int fd) : fd_(fd) {}
  OwnedFd(OwnedFd&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
  OwnedFd& operator=(OwnedFd&& other) noexcept {
    if (this != &other) {
      reset();
      fd_ = std::exchange(other.fd_, -1);
    }
    return *this;
  }
  OwnedFd(const OwnedFd&) = delete;
  OwnedFd& operator=(const OwnedFd&) = delete;
  ~OwnedFd() { reset(); }
  [[nodiscard]] int get() const { return fd_; }
  void reset() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_ = -1;
};

// A pipe's two ends (O_CLOEXEC). Throws lbpkit::Error naming what it is
// for when the kernel makes none.
struct Pipe {
  OwnedFd read, write;
};
Pipe makePipe(const std::string& what) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw lbpkit::Error("cannot make a pipe for " + what);
  return {OwnedFd(fds[0]), OwnedFd(fds[1])};
}

// The PID namespace a process is in (an inode number), or 0.
unsigned long pidNamespace(const std::string& pid) {
  struct stat st {};
  return ::stat(("/proc/" + pid + "/ns/pid").c_str(), &st) == 0 ? static_cast<unsigned long>(st.st_ino) : 0;
}

// Stops LinuxCNC as closing its display does: SIGTERM to every process of
// its PID namespace (the display, whose end the linuxcnc script waits for,
// the task, the servers, rtapi_app) and to the script (the starting child's,
// PID 1 there), whose trap then unloads HAL. If it has not ended in 10 s,
// SIGKILL to the child that waits for it (startLinuxCnc), whose death takes
// LinuxCNC's PID 1, and with it the namespace, along (PR_SET_PDEATHSIG).
int stopLinuxCnc(pid_t starter) {
  std::ifstream children(fmt::format("/proc/{}/task/{}/children", starter, starter));
  pid_t script = 0;
  children >> script;
  if (const unsigned long ns = script > 0 ? pidNamespace(std::to_string(script)) : 0; ns != 0) {
    std::error_code ec;
    for (const auto& p : fs::directory_iterator("/proc", ec)) {
      const auto name = p.path().filename().string();
      if (name.find_first_not_of("0123456789") == std::string::npos && pidNamespace(name) == ns)
        ::kill(static_cast<pid_t>(std::stoi(name)), SIGTERM);
    }
  }
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  int status = 0;
  while (::waitpid(starter, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline || script <= 0) {
      ::kill(starter, SIGKILL);
      ::waitpid(starter, &status, 0);
      break;
    }
    std::this_thread::sleep_for(20ms);
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// The copy of LinuxCNC's standard error that the linuxcnc script leaves in
// its user's home when it fails at start-up (linuxcnc_debug.txt, beside
// linuxcnc_print.txt): printed when this run wrote it. Read by root only if
// it is that user's own regular file (linuxcnc_run::readUsersFile). False
// when there is none.
bool printLinuxCncDebugFile(const app::linuxcnc_run::RunAs& user, std::chrono::system_clock::time_point started) {
  const fs::path log = fs::path(user.home) / "linuxcnc_debug.txt";
  const auto text = app::linuxcnc_run::readUsersFile(log, user.uid, started, 64 * 1024);
  if (!text) return false;
  std::vector<std::string> lines;
  std::size_t from = 0;
  for (std::size_t nl; (nl = text->find('\n', from)) != std::string::npos; from = nl + 1) {
    const auto line = text->substr(from, nl - from);
    if (line.find("Running with fallback_uid") == std::string::npos) lines.push_back(line);
  }
  fmt::print("lbpkit linuxcnc: the end of LinuxCNC's {} (the whole of it there, and linuxcnc_print.txt beside it):\n",
             log.string());
  for (std::size_t i = lines.size() > 20 ? lines.size() - 20 : 0; i < lines.size(); ++i) fmt::print("  | {}\n", lines[i]);
  return true;
}

// The folders under /tmp that LinuxCNC's own /tmp keeps, bound in from the
// PC's: the X server's sockets (/tmp/.X11-unix, for the user's display) and
// the folder under /tmp of every absolute path in `paths` (the
// configuration, a display program and its files).
std::vector<std::string> keptInTmp(const std::vector<std::string>& paths) {
  std::vector<std::string> keep;
  auto add = [&](const std::string& name) {
    struct stat st {};
    if (!name.empty() && name != "." && name != ".." && std::find(keep.begin(), keep.end(), name) == keep.end() &&
        ::lstat(("/tmp/" + name).c_str(), &st) == 0 && S_ISDIR(st.st_mode))
      keep.push_back(name);
  };
  add(".X11-unix");
  for (const auto& text : paths)
    for (auto at = text.find("/tmp/"); at != std::string::npos; at = text.find("/tmp/", at + 1))
      if (at == 0 || text[at - 1] == ' ' || text[at - 1] == '=') {
        const auto name = text.substr(at + 5, text.find_first_of("/ \t", at + 5) - (at + 5));
        add(name);
      }
  return keep;
}

// How LinuxCNC is started (startLinuxCnc).
struct LinuxCncLaunch {
  app::linuxcnc_run::RunAs user;
  std::string netns;           // the network namespace's name (/run/netns/NAME)
  std::string privateTmp;      // the run's folder for LinuxCNC's /tmp (root's, 0700 until bound)
  std::vector<std::string> keep;  // keptInTmp
  std::string linuxcnc;        // the linuxcnc script's absolute path (in `root` when given)
  std::string root;            // --linuxcnc-root: another release's LinuxCNC, or "" for this PC's
  std::string ini;
  std::string fifo;            // rtapi_app's socket (RTAPI_FIFO_PATH)
  std::optional<unsigned> cpu;
};

// In the forked child that becomes LinuxCNC's PID 1: says why it cannot
// go on, and ends.
[[noreturn]] void refuse(const char* what) {
  const int e = errno;
  const std::string text = fmt::format("lbpkit linuxcnc: cannot start LinuxCNC: {}: {}\n", what, std::strerror(e));
  (void)!::write(2, text.data(), text.size());
  ::_exit(126);
}

// Starts LinuxCNC without a shell: a child (the caller waits for it) that
// enters new PID, mount and IPC namespaces and forks LinuxCNC's PID 1, which
// joins the network namespace, mounts its own /proc and /tmp, drops to the
// user and execs the linuxcnc script. Each dies with its parent
// (PR_SET_PDEATHSIG), so that a killed lbpkit takes LinuxCNC with it. The
// child's pid, which ends with LinuxCNC's exit status.
pid_t startLinuxCnc(const LinuxCncLaunch& l) {
  const pid_t pid = app::linuxcnc_run::forkInRun();
  if (pid < 0) throw lbpkit::Error("cannot start LinuxCNC: fork failed");
  if (pid > 0) {
    ::setpgid(pid, pid);
    return pid;
  }
  // The child (as unshare --fork would be): in a process group of its own,
  // so that a terminal's Ctrl-C reaches only lbpkit, which stops it in order.
  ::setpgid(0, 0);
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // and should lbpkit be gone already, the reaper kills it
  pinTo(l.cpu);
  if (::unshare(CLONE_NEWPID | CLONE_NEWNS | CLONE_NEWIPC) != 0) refuse("new PID, mount and IPC namespaces");
  const pid_t script = ::fork();
  if (script < 0) refuse("fork");
  if (script > 0) {
    int status = 0;
    while (::waitpid(script, &status, 0) < 0 && errno == EINTR) {
    }
    if (WIFSIGNALED(status)) {  // killed: said as a kill, as a shell's child would be
      ::signal(WTERMSIG(status), SIG_DFL);
      ::kill(::getpid(), WTERMSIG(status));
    }
    ::_exit(WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0));
  }
  // LinuxCNC's PID 1: when it ends, everything LinuxCNC started ends.
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0) refuse("a private mount namespace");
  if (::mount("proc", "/proc", "proc", MS_NOSUID | MS_NODEV | MS_NOEXEC, nullptr) != 0) refuse("its own /proc");
  const int net = ::open(("/run/netns/" + l.netns).c_str(), O_RDONLY | O_CLOEXEC);
  if (net < 0 || ::setns(net, CLONE_NEWNET) != 0) refuse("the network namespace");
  ::close(net);
  // As `ip netns exec` does: /sys shows this namespace's links.
  if (::umount2("/sys", MNT_DETACH) == 0) ::mount("sysfs", "/sys", "sysfs", 0, nullptr);
  // Its own /tmp: the run's folder, with what it keeps bound in. Every
  // path is opened without following a link and mounted through its
  // descriptor.
  const int priv = ::open(l.privateTmp.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (priv < 0) refuse(l.privateTmp.c_str());
  for (const auto& name : l.keep) {
    const int from = ::open(("/tmp/" + name).c_str(), O_PATH | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (from < 0) continue;
    if (::mkdirat(priv, name.c_str(), 0755) != 0) refuse(name.c_str());
    const int to = ::openat(priv, name.c_str(), O_PATH | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (to < 0 || ::mount(fmt::format("/proc/self/fd/{}", from).c_str(), fmt::format("/proc/self/fd/{}", to).c_str(),
                          nullptr, MS_BIND | MS_REC, nullptr) != 0)
      refuse(("/tmp/" + name).c_str());
    ::close(from);
    ::close(to);
  }
  if (::mount(fmt::format("/proc/self/fd/{}", priv).c_str(), "/tmp", nullptr, MS_BIND | MS_REC, nullptr) != 0)
    refuse("its own /tmp");
  ::close(priv);
  // As /tmp: LinuxCNC runs as the user, rtapi_app perhaps as nobody.
  const int tmp = ::open("/tmp", O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (tmp < 0 || ::fchmod(tmp, 01777) != 0) refuse("/tmp's mode");
  ::close(tmp);
  if (!l.root.empty()) {
    if (const auto problem = lbpkit::linuxcnc::enterLinuxCncRoot(l.root); !problem.empty()) {
      const std::string text = fmt::format("lbpkit linuxcnc: cannot start LinuxCNC: {}\n", problem);
      (void)!::write(2, text.data(), text.size());
      ::_exit(126);
    }
  }
  if (!app::linuxcnc_run::dropTo(l.user)) refuse(("the user " + l.user.name).c_str());
  ::prctl(PR_SET_PDEATHSIG, SIGKILL);  // a change of user clears it
  if (l.user.root) {
    ::setenv("RTAPI_UID", "65534", 1);
  } else {
    ::setenv("HOME", l.user.home.c_str(), 1);
    ::setenv("USER", l.user.name.c_str(), 1);
    ::setenv("LOGNAME", l.user.name.c_str(), 1);
  }
  ::setenv("RTAPI_FIFO_PATH", l.fifo.c_str(), 1);
  ::execl(l.linuxcnc.c_str(), "linuxcnc", l.ini.c_str(), static_cast<char*>(nullptr));
  refuse(l.linuxcnc.c_str());
}

// The card a board's HAL name is (hm2_7i92.0 -> 7I92), or empty.
std::string cardOfBoard(const std::string& prefix) {
  const auto name = lbpkit::linuxcnc::hal_name::parse(prefix);
  if (!name) return {};
  for (const auto& card : hm2::cards::all())
    if (card.halName == name->board) return std::string(card.name);
  return {};
}

// The [EMC]VERSION of a configuration from before LinuxCNC 2.8's joints
// (below 1.1, or none: "" then), which linuxcnc converts with update_ini
// before it runs it; nothing for a newer one.
std::optional<std::string> olderThanJoints(const lbpkit::linuxcnc::Ini& ini) {
  const auto* entry = ini.find("EMC", "VERSION");
  const std::string version = entry != nullptr ? entry->value : std::string();
  double v = 0.0;
  try {
    v = std::stod(version);
  } catch (const std::exception&) {
  }
  if (v < 1.1) return version;
  return std::nullopt;
}

// A copy of the configuration in `into`, as LinuxCNC would run it on the
// virtual card: a PCI card's configuration (hm2_pci, a 5I25 or 6I25) on the
// 7I92 at 10.10.10.10 (hm2_eth, its pins hm2_7i92.0.*, no firmware= to
// load), and `display` in place of [DISPLAY]DISPLAY; converted with
// update_ini when `convertFrom` holds the [EMC]VERSION of a configuration
// from before LinuxCNC 2.8 (olderThanJoints). Returns the copy's INI.
fs::path copyConfiguration(const fs::path& ini, const fs::path& into, const std::vector<std::string>& pciPrefixes,
                           const std::string& display, const std::optional<std::string>& convertFrom) {
  fs::create_directories(into);
  fs::copy(ini.parent_path(), into, fs::copy_options::recursive | fs::copy_options::overwrite_existing |
                                        fs::copy_options::skip_symlinks);
  auto rewrite = [&](const fs::path& file) {
    std::ifstream in(file);
    std::string text, line;
    bool inDisplay = false;
    while (std::getline(in, line)) {
      std::string out = line;
      for (const auto& prefix : pciPrefixes)
        for (auto at = out.find(prefix + "."); at != std::string::npos; at = out.find(prefix + ".", at))
          out.replace(at, prefix.size(), "hm2_7i92.0");
      const auto first = out.find_first_not_of(" \t");
      const bool loadrt = first != std::string::npos && out.compare(first, 7, "loadrt ") == 0;
      if (loadrt && (out.find("hm2_pci") != std::string::npos || out.find("DRIVER") != std::string::npos)) {
        // loadrt hm2_pci config="firmware=... num_encoders=..." -> hm2_eth
        const auto word = out.find_first_not_of(" \t", first + 7);
        const auto end = out.find_first_of(" \t", word);
        out = out.substr(0, word) + "hm2_eth board_ip=10.10.10.10" + (end == std::string::npos ? "" : out.substr(end));
        for (auto f = out.find("firmware="); f != std::string::npos; f = out.find("firmware=")) {
          const auto stop = out.find_first_of(" \t\"", f);
          out.erase(f, stop == std::string::npos ? std::string::npos : stop - f + (out[stop] == '"' ? 0 : 1));
        }
      }
      if (file.extension() == ".ini") {
        const auto t = out.find_first_not_of(" \t");
        if (t != std::string::npos && out[t] == '[') inDisplay = out.compare(t, 9, "[DISPLAY]") == 0;
        if (inDisplay && !display.empty() && t != std::string::npos && out.compare(t, 7, "DISPLAY") == 0 &&
            out.find('=') != std::string::npos)
          out = "DISPLAY = " + display;
        if (out.find("hm2_pci") != std::string::npos && out.find('=') != std::string::npos)
          out.replace(out.find("hm2_pci"), 7, "hm2_eth");
      }
      text += out + "\n";
    }
    in.close();
    std::ofstream(file, std::ios::trunc) << text;
  };
  for (const auto& e : fs::recursive_directory_iterator(into))
    if (e.is_regular_file() && (e.path().extension() == ".hal" || e.path().extension() == ".ini")) rewrite(e.path());
  const auto copy = into / ini.filename();
  // A configuration older than LinuxCNC 2.8's joints: linuxcnc would ask,
  // in a dialog, to convert it with update_ini; the copy is converted
  // without asking (update_ini -f), as that dialog's "yes" would.
  if (const auto& version = convertFrom) {
    fmt::print("lbpkit linuxcnc: {} is a configuration from before LinuxCNC 2.8 ([EMC]VERSION {}): the copy is "
               "converted with update_ini -f, as linuxcnc's own dialog offers\n",
               ini.filename().string(), version->empty() ? "none" : *version);
    std::fflush(stdout);
    const auto converted = lbpkit::process::runProgram({"update_ini", "-f", copy.string()});
    if (converted.status != 0)
      throw lbpkit::Error(fmt::format("{}: update_ini -f could not convert it (LinuxCNC could not either): {}",
                                      ini.string(), converted.output));
  }
  return copy;
}

// What check-config found that LinuxCNC would refuse, printed as
// check-config prints it: how many.
unsigned printErrors(const lbpkit::linuxcnc::CheckResult& result) {
  unsigned errors = 0;
  for (const auto& f : result.findings)
    if (f.severity == "error") {
      ++errors;
      fmt::print(stderr, "{}:{}: error: {}\n", f.file, f.line, f.reason);
    }
  return errors;
}

// What a configuration is and what the run needs of it, found by
// prepareAsUser.
struct Prepared {
  std::string error;  // why it cannot run; empty when it can
  std::string boardIp, card;
  std::vector<std::string> pciPrefixes;
  bool machineText = false;  // `machine` is a machine file's text (else a built-in's name)
  std::string machine;
  std::string run;  // the INI LinuxCNC runs: the configuration's or its copy's
  long servoPeriodNs = 0;  // [EMCMOT]SERVO_PERIOD, when lbpkit sim --clock host takes it
  std::string servoPeriodAt;  // "mill.ini:60"
};

void to_json(nlohmann::json& j, const Prepared& p) {
  j = {{"error", p.error}, {"boardIp", p.boardIp}, {"card", p.card}, {"pci", p.pciPrefixes},
       {"machineText", p.machineText}, {"machine", p.machine}, {"run", p.run}, {"servoPeriodNs", p.servoPeriodNs},
       {"servoPeriodAt", p.servoPeriodAt}};
}
void from_json(const nlohmann::json& j, Prepared& p) {
  p.error = j.at("error");
  p.boardIp = j.at("boardIp");
  p.card = j.at("card");
  p.pciPrefixes = j.at("pci").get<std::vector<std::string>>();
  p.machineText = j.at("machineText");
  p.machine = j.at("machine");
  p.run = j.at("run");
  p.servoPeriodNs = j.at("servoPeriodNs");
  p.servoPeriodAt = j.at("servoPeriodAt");
}

// What the configuration loads, checked as lbpkit check-config checks it
// (LinuxCNC would refuse a configuration with errors), the machine it
// expects, and the copy LinuxCNC runs when it needs one, in `userFolder`.
// Run as the user LinuxCNC will run as: nothing of the user's is read as
// root.
Prepared prepare(const LinuxCncOptions& o, const fs::path& userFolder) {
  Prepared p;
  const fs::path ini = fs::absolute(o.ini);
  if (!fs::is_regular_file(ini)) throw lbpkit::Error(fmt::format("{}: no such configuration file", o.ini));
  const auto result = lbpkit::linuxcnc::checkConfig(ini, app::catalogueBoardModel(o.card, {}));
  const unsigned errors = printErrors(result);
  if (errors > 0)
    throw lbpkit::Error(fmt::format("{}: {} error{} that LinuxCNC would refuse (lbpkit check-config {} says more)",
                                    o.ini, errors, errors == 1 ? "" : "s", o.ini));
  const lbpkit::linuxcnc::Board* board = nullptr;
  for (const auto& b : result.boards) {
    if (b.driver == "hm2_eth" && board == nullptr) board = &b;
    if (b.driver == "hm2_pci") p.pciPrefixes.push_back(b.prefix);
  }
  if (board == nullptr && p.pciPrefixes.empty())
    throw lbpkit::Error(fmt::format("{}: loads no Mesa card (loadrt hm2_eth or hm2_pci)", o.ini));
  if (board != nullptr && board->boardIp.empty())
    throw lbpkit::Error(fmt::format("{}:{}: loadrt hm2_eth has no board_ip=", board->file, board->line));
  // A PCI card cannot be on a veth pair: its configuration runs as the same
  // 7I77 on a 7I92 (Mesa's 7I77x2 firmware has the same modules on both).
  const bool pci = board == nullptr;
  p.boardIp = pci ? std::string("10.10.10.10") : board->boardIp;
  if (const auto problem = lbpkit::linuxcnc::boardAddressProblem(p.boardIp)) {
    // check-config's word on it, at the INI's line (a loopback address is
    // only a warning there: lbpkit sim on this PC answers at one).
    for (const auto& f : result.findings)
      if (f.name == "board_ip" && f.severity != "error") fmt::print(stderr, "{}:{}: {}: {}\n", f.file, f.line, f.severity, f.reason);
    throw lbpkit::Error(pci ? *problem : fmt::format("{}:{}: board_ip: {}", board->file, board->line, *problem));
  }
  p.card = !o.card.empty() ? o.card : pci ? std::string("7I92") : cardOfBoard(board->prefix);

  if (o.machine == "auto") {
    p.machineText = true;
    p.machine = app::deriveMachineFile(ini, userFolder / "machine.toml", true);
    fmt::print("lbpkit linuxcnc: the machine {} expects (lbpkit machine --from-config {} writes it)\n", o.ini, o.ini);
  } else if (o.machine != "mill" && o.machine != "lathe" && o.machine != "gantry") {
    // A machine file of the user's: read here, as the user; the sim (root)
    // reads the run's copy.
    constexpr std::uintmax_t kLargest = 1 << 20;
    std::error_code ec;
    if (!fs::is_regular_file(o.machine, ec) || fs::file_size(o.machine, ec) > kLargest)
      throw lbpkit::Error(fmt::format("--machine {}: not a machine file (a regular file of at most 1 MiB) or a built-in "
                                      "machine (mill, lathe, gantry, auto)",
                                      o.machine));
    std::ifstream in(o.machine);
    p.machineText = true;
    p.machine.assign(std::istreambuf_iterator<char>(in), {});
  } else {
    p.machine = o.machine;
  }
  // What a servo thread that runs late needs (linuxcnc_host.hpp): the
  // servo period for the sim's host clock, and where the configuration
  // sets hm2_eth's wait for a reply itself.
  const auto& hal = result.hal;
  std::vector<std::string> boards;
  if (pci) boards.push_back("hm2_7i92.0");
  for (const auto& b : result.boards)
    if (b.driver == "hm2_eth") boards.push_back(b.prefix);
  std::sort(boards.begin(), boards.end());
  boards.erase(std::unique(boards.begin(), boards.end()), boards.end());
  if (const auto* period = hal.ini.find("EMCMOT", "SERVO_PERIOD")) {
    p.servoPeriodNs = app::linuxcnc_host::servoPeriodForClock(period->value);
    p.servoPeriodAt = fmt::format("{}:{}", period->file.empty() ? ini.filename().string() : period->file, period->line);
  } else {
    p.servoPeriodNs = 1'000'000;  // LinuxCNC's own when the INI gives none
    p.servoPeriodAt = "LinuxCNC's default, no [EMCMOT]SERVO_PERIOD";
  }
  p.run = ini.string();
  const auto oldVersion = olderThanJoints(hal.ini);
  const bool convert = oldVersion.has_value();
  if (pci || !o.display.empty() || o.lateServo || convert) {
    p.run = copyConfiguration(ini, userFolder / "config", p.pciPrefixes, o.display, oldVersion).string();
    if (convert) {
      // What LinuxCNC's start-up check will say of the converted copy, said
      // before anything starts (lbpkit check-config on it).
      const unsigned refused = printErrors(lbpkit::linuxcnc::checkConfig(p.run, app::catalogueBoardModel(o.card, {})));
      if (refused > 0)
        throw lbpkit::Error(fmt::format(
            "{}: as update_ini converts it ({}), it has {} error{} that LinuxCNC would refuse: the lines above are the "
            "converted copy's; change the original's [JOINT_n] and [AXIS_L] sections to match",
            o.ini, p.run, refused, refused == 1 ? "" : "s"));
    }
    if (o.lateServo) {
      const fs::path copy = p.run;
      std::ofstream(copy.parent_path() / app::linuxcnc_host::kLateServoHalFile)
          << app::linuxcnc_host::lateServoHal(boards);
      std::ifstream in(copy);
      const std::string text(std::istreambuf_iterator<char>(in), {});
      in.close();
      std::ofstream(copy, std::ios::trunc)
          << app::linuxcnc_host::withLastHalFile(text, app::linuxcnc_host::kLateServoHalFile);
      // Each change, with the configuration's own setp it stands in for.
      auto said = [&](const std::string& parameter) {
        const auto* own = hal.setpOf(parameter);
        return own != nullptr ? fmt::format(", in place of {}:{}'s {}", own->at.file, own->at.line, own->value)
                              : std::string();
      };
      for (const auto& name : boards) {
        fmt::print("  - {}.packet-read-timeout {} ({} ms; hm2_eth's own wait is 80 % of a servo period, on the wall "
                   "clock){}\n",
                   name, app::linuxcnc_host::kPacketReadTimeoutNs, app::linuxcnc_host::kPacketReadTimeoutNs / 1'000'000,
                   said(name + ".packet-read-timeout"));
        fmt::print("  - {}.watchdog.timeout_ns {} ({} ms: a servo thread held back is still alive; a LinuxCNC that "
                   "stopped still meets the 7I77's own 50 ms watchdog){}\n",
                   name, app::linuxcnc_host::kHostMot2WatchdogNs, app::linuxcnc_host::kHostMot2WatchdogNs / 1'000'000,
                   said(name + ".watchdog.timeout_ns"));
      }
      fmt::print("  - both in {}, the copy's last HALFILE\n", app::linuxcnc_host::kLateServoHalFile);
      fmt::print("  - the copy of the configuration: {}\n", copy.parent_path().string());
    }
    if (pci)
      fmt::print("lbpkit linuxcnc: {} is a PCI card (hm2_pci): running a copy of the configuration with the same "
                 "7I77 on a 7I92 at 10.10.10.10 (hm2_eth, pins hm2_7i92.0.*) in {}\n",
                 p.pciPrefixes.front(), fs::path(p.run).parent_path().string());
    if (!o.display.empty()) fmt::print("lbpkit linuxcnc: the display is {} ([DISPLAY]DISPLAY in the copy)\n", o.display);
  }
  return p;
}

// prepare(), in a child that runs as `user`; what it found comes back
// through a pipe. Throws lbpkit::Error with the child's reason.
Prepared prepareAsUser(const LinuxCncOptions& o, const fs::path& userFolder, const app::linuxcnc_run::RunAs& user) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw lbpkit::Error("cannot make a pipe");
  const pid_t pid = app::linuxcnc_run::forkInRun();
  if (pid < 0) throw lbpkit::Error("cannot read the configuration: fork failed");
  if (pid == 0) {
    ::close(fds[0]);
    Prepared p;
    try {
      if (!app::linuxcnc_run::dropTo(user))
        throw lbpkit::Error(fmt::format("cannot run as {} (uid {})", user.name, user.uid));
      p = prepare(o, userFolder);
    } catch (const std::exception& e) {
      p.error = e.what();
    }
    const auto text = nlohmann::json(p).dump();
    std::size_t done = 0;
    while (done < text.size()) {
      const auto n = ::write(fds[1], text.data() + done, text.size() - done);
      if (n <= 0) break;
      done += static_cast<std::size_t>(n);
    }
    std::fflush(stdout);
    std::fflush(stderr);
    ::_exit(0);
  }
  ::close(fds[1]);
  std::string text;
  char buf[4096];
  for (ssize_t n; (n = ::read(fds[0], buf, sizeof buf)) != 0;) {
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) break;
    text.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  Prepared p;
  try {
    p = nlohmann::json::parse(text).get<Prepared>();
  } catch (const std::exception&) {
    throw lbpkit::Error(fmt::format("{}: reading the configuration as {} failed (exit status {})", o.ini, user.name,
                                    WIFEXITED(status) ? WEXITSTATUS(status) : -1));
  }
  if (!p.error.empty()) throw lbpkit::Error(p.error);
  return p;
}

// One `lbpkit linuxcnc`: the run's folder, its network namespace, the sim
// (and the pipes it writes to) and LinuxCNC, each made by a step of run()
// and owned by a member. However the run ends (LinuxCNC or the sim ended,
// Ctrl-C, an error), its destruction undoes what was made, once and in
// order: LinuxCNC stopped, the sim stopped and its last output shown, its
// pipes closed, the namespace removed, the run's folder removed.
class LinuxCncRun {
 public:
  explicit LinuxCncRun(const LinuxCncOptions& o) : o_(o), options_(o) {}
  ~LinuxCncRun();
  LinuxCncRun(const LinuxCncRun&) = delete;
  LinuxCncRun& operator=(const LinuxCncRun&) = delete;

  // The run, until LinuxCNC or the sim ends or Ctrl-C: its exit status
  // (LinuxCNC's; 130 on Ctrl-C, 1 when the sim ended). Throws
  // lbpkit::Error when it cannot start.
  int run();

 private:
  // What the run needs and checks before it makes anything, then its
  // reaper, its folder and the configuration read as the user.
  void prepare();
  // The card's address, checked against this PC's before anything is
  // built, and both addresses claimed (the namespace's link and routes
  // made) before another run may choose.
  void makeNamespace();
  // The sim on the configuration's board_ip, hm2_eth's port, its API and
  // web view on this PC's loopback.
  void startSim();
  // Until the sim greets (its card, control API and web view serving); its
  // output, its banner among it, goes to the user meanwhile.
  void awaitSim();
  // LinuxCNC in the namespace (startLinuxCnc), and the --ready-fd greeting.
  LinuxCncLaunch startLinuxCncInRun();
  // Until LinuxCNC or the sim ends, or Ctrl-C: the run's exit status.
  int watch(const LinuxCncLaunch& launch);
  // The sim's output, when some comes within `timeoutMs`, shown to the user.
  bool readSim(int timeoutMs);

  const LinuxCncOptions& o_;
  LinuxCncOptions options_;  // o_, with what the PC decides (lateServo)
  std::chrono::system_clock::time_point started_ = std::chrono::system_clock::now();
  app::linuxcnc_run::RunAs user_;
  std::string linuxcnc_;       // the linuxcnc script
  std::string nsName_, link_;  // the run's network namespace and link
  std::optional<app::linuxcnc_run::RunFolder> folder_;
  Prepared p_;
  std::string machine_;  // lbpkit sim --machine
  std::optional<unsigned> cpu_;
  std::optional<lbpkit::linuxcnc::NetworkNamespace> ns_;
  OwnedFd simOut_, simReady_;  // the sim's output and greeting
  std::string simText_, greeting_;
  pid_t sim_ = -1, lcnc_ = -1;  // -1: not started, or ended and reaped
};

LinuxCncRun::~LinuxCncRun() {
  // LinuxCNC and the sim are stopped here; the members then close the
  // sim's pipes, remove the namespace and the run's folder.
  try {
    if (lcnc_ > 0) stopLinuxCnc(lcnc_);
    if (sim_ > 0) stop(sim_, 10s);
    while (simOut_.get() >= 0 && readSim(0)) {
    }
  } catch (...) {  // a destructor that throws while an error unwinds ends the program
  }
}

void LinuxCncRun::prepare() {
  namespace run = app::linuxcnc_run;
  if (::geteuid() != 0)
    throw lbpkit::Error("lbpkit linuxcnc needs root (a network namespace and a veth pair): run it with sudo");
  // --ready-fd: a descriptor of the caller's, kept from everything the run
  // starts (the greeting is written once, by this process).
  if (o_.readyFd >= 0 && ::fcntl(o_.readyFd, F_SETFD, FD_CLOEXEC) != 0)
    throw lbpkit::Error(fmt::format("--ready-fd {}: no such open descriptor", o_.readyFd));
  user_ = run::invokingUser();
  if (o_.linuxcncRoot.empty()) {
    const auto found = lbpkit::process::systemProgram("linuxcnc");
    if (!found) throw lbpkit::Error("linuxcnc is not installed (Debian's linuxcnc-uspace)");
    linuxcnc_ = *found;
  } else {
    // Checked here, entered by LinuxCNC's PID 1 (startLinuxCnc).
    if (const auto problem = lbpkit::linuxcnc::linuxCncRootProblem(o_.linuxcncRoot); !problem.empty())
      throw lbpkit::Error(fmt::format("--linuxcnc-root {}", problem));
    linuxcnc_ = "/usr/bin/linuxcnc";
  }
  if (!lbpkit::process::systemProgram("ip")) throw lbpkit::Error("ip is not installed (Debian's iproute2)");

  // What runs that are gone left, then this run's own: its names carry
  // this process's pid (linuxcnc_run.hpp).
  run::removeDeadRuns();
  const pid_t self = ::getpid();
  nsName_ = run::namespaceName(self);
  link_ = run::linkName(self);
  // From here whatever the run makes and starts ends with it.
  run::startReaper(self, nsName_, link_);
  folder_.emplace(self);
  const auto userFolder = folder_->makeFolder("user", 0755, user_);
  // Real-time or not, as LinuxCNC will find it (linuxcnc_host.hpp).
  const auto realTime = app::linuxcnc_host::detectRealTime();
  options_.lateServo = !realTime.yes && !o_.asWritten;
  if (realTime.yes)
    fmt::print("lbpkit linuxcnc: LinuxCNC runs real-time on this PC ({}): the configuration runs as written, the sim "
               "on the wall clock\n",
               realTime.why);
  else if (o_.asWritten)
    fmt::print("lbpkit linuxcnc: LinuxCNC will not run real-time on this PC ({}); --as-written: the configuration "
               "runs untouched, the sim on the wall clock, where a servo thread that runs late finds a card that did "
               "not wait for it (docs/clocks.md)\n",
               realTime.why);
  else
    fmt::print("lbpkit linuxcnc: LinuxCNC will not run real-time on this PC ({}), so its servo thread runs late now "
               "and then; it runs as an on-time machine would (--as-written runs it untouched):\n",
               realTime.why);
  std::fflush(stdout);
  p_ = prepareAsUser(options_, userFolder, user_);
  machine_ = p_.machine;
  if (p_.machineText) machine_ = folder_->writeFile("machine.toml", p_.machine).string();
}

void LinuxCncRun::makeNamespace() {
  namespace run = app::linuxcnc_run;
  const lbpkit::linuxcnc::AddressClaim claim;
  const auto board = lbpkit::linuxcnc::parseIpv4(p_.boardIp);
  if (!board) throw lbpkit::Error(fmt::format("board_ip {}: not an IPv4 address", p_.boardIp));
  if (const auto problem = run::hostAddressProblem(*board)) throw lbpkit::Error(fmt::format("board_ip: {}", *problem));
  const auto peer = run::peerFor(*board);
  if (!peer)
    throw lbpkit::Error(
        fmt::format("board_ip {}: every other address of its /24 is this PC's already; LinuxCNC's side "
                    "needs one",
                    p_.boardIp));
  const std::string peerIp = lbpkit::linuxcnc::formatIpv4(*peer);

  app::installSignalHandlers();
  ns_.emplace(nsName_,
              std::vector<lbpkit::linuxcnc::VethLink>{{link_, p_.boardIp + "/32", peerIp + "/24", peerIp + "/32"}});
}

void LinuxCncRun::startSim() {
  auto out = makePipe("the sim's output");
  // The sim's greeting (lbpkit sim --ready-fd 3): it serves, and where.
  auto ready = makePipe("the sim's greeting");
  std::vector<std::string> simArgv = {"/proc/self/exe", "sim",         "--bind",     p_.boardIp,
                                      "--api",          "127.0.0.1:0", "--ready-fd", "3"};
  if (!p_.card.empty()) simArgv.insert(simArgv.end(), {"--card", p_.card});
  if (!machine_.empty()) simArgv.insert(simArgv.end(), {"--machine", machine_});
  // LinuxCNC and the card thread on one CPU: each datagram hm2_eth sends
  // wakes the card thread (SCHED_FIFO) on that CPU at once, and the reply is
  // there before hm2_eth looks for it, whatever else the PC runs. hm2_eth's
  // set-up gives each read 1.6 ms (LinuxCNC: hm2_eth.c), mesaflash's
  // discovery 2 ms; a real card answers in microseconds.
  cpu_ = app::cpuOption(o_.cpu);
  if (cpu_) simArgv.insert(simArgv.end(), {"--cpu", std::to_string(*cpu_)});
  // On the host clock where the servo thread runs late, unless the sim's
  // options after -- choose a clock.
  const bool clockGiven = std::any_of(o_.simArguments.begin(), o_.simArguments.end(), [](const std::string& a) {
    return a == "--clock" || a.rfind("--clock=", 0) == 0;
  });
  if (options_.lateServo && !clockGiven) {
    const std::string clock = p_.servoPeriodNs > 0 ? fmt::format("host={}", p_.servoPeriodNs) : std::string("host");
    simArgv.insert(simArgv.end(), {"--clock", clock});
    fmt::print(
        "  - the sim keeps time by LinuxCNC's servo cycles (--clock {}, [EMCMOT]SERVO_PERIOD: {}): a period "
        "that runs late is one period to the machine, as it is to LinuxCNC (docs/clocks.md)\n",
        clock, p_.servoPeriodAt);
  } else if (options_.lateServo) {
    fmt::print("  - the sim on the clock its options after -- give\n");
  }
  simArgv.insert(simArgv.end(), o_.simArguments.begin(), o_.simArguments.end());
  sim_ = spawn(simArgv, out.write.get(), ready.write.get());
  simOut_ = std::move(out.read);
  simReady_ = std::move(ready.read);
}

bool LinuxCncRun::readSim(int timeoutMs) {
  pollfd pfd{simOut_.get(), POLLIN, 0};
  if (::poll(&pfd, 1, timeoutMs) <= 0) return false;
  char buf[4096];
  const auto n = ::read(simOut_.get(), buf, sizeof buf);
  if (n <= 0) return false;
  const std::string chunk(buf, static_cast<std::size_t>(n));
  simText_ += chunk;
  fmt::print("{}", chunk);
  std::fflush(stdout);
  return true;
}

void LinuxCncRun::awaitSim() {
  const auto deadline = std::chrono::steady_clock::now() + 15s;
  bool readyOpen = true;
  while (greeting_.find('\n') == std::string::npos) {
    if (app::gStop || !readyOpen || std::chrono::steady_clock::now() > deadline ||
        ::waitpid(sim_, nullptr, WNOHANG) == sim_) {
      sim_ = -1;  // left to the reaper
      throw lbpkit::Error("lbpkit sim did not start (its output is above)");
    }
    readSim(0);
    pollfd pfd{simReady_.get(), POLLIN, 0};
    if (::poll(&pfd, 1, 100) <= 0) continue;
    char buf[4096];
    const auto n = ::read(simReady_.get(), buf, sizeof buf);
    if (n <= 0)
      readyOpen = false;
    else
      greeting_.append(buf, static_cast<std::size_t>(n));
  }
  readSim(0);
}

LinuxCncLaunch LinuxCncRun::startLinuxCncInRun() {
  // LinuxCNC in the namespace, and in PID, IPC and mount namespaces of
  // its own: whatever it starts ends with it, its HAL's shared memory goes
  // with it however it ends (a killed LinuxCNC leaves System V segments
  // behind that the next start trips over), and its /tmp is the run's
  // own, so that the linuxcnc script's lock file (/tmp/linuxcnc.lock)
  // neither stops nor is stopped by another LinuxCNC on this PC.
  LinuxCncLaunch launch;
  launch.user = user_;
  launch.netns = nsName_;
  launch.privateTmp = folder_->makeFolder("tmp", 0700, app::linuxcnc_run::RunAs{}).string();
  launch.keep = keptInTmp({fs::absolute(o_.ini).string(), p_.run, o_.display});
  launch.linuxcnc = linuxcnc_;
  launch.root = o_.linuxcncRoot;
  launch.ini = p_.run;
  launch.fifo = "/tmp/rtapi_fifo";  // rtapi_app's socket, in LinuxCNC's own /tmp
  launch.cpu = cpu_;
  fmt::print("lbpkit linuxcnc: LinuxCNC ({}{}) in network namespace {}, the card {} at {}{}; Ctrl-C stops both\n",
             p_.run, o_.linuxcncRoot.empty() ? std::string() : ", from " + o_.linuxcncRoot, ns_->name(), p_.card,
             p_.boardIp, cpu_ ? fmt::format(", both on CPU {}", *cpu_) : std::string());
  std::fflush(stdout);
  lcnc_ = startLinuxCnc(launch);
  if (o_.readyFd >= 0) {
    // --ready-fd: the run's greeting for a program that drives it (the
    // sim's, the namespace and the copy LinuxCNC runs), then closed.
    const nlohmann::json ready = {
        {"lbpkit", "linuxcnc"},
        {"sim", nlohmann::json::parse(greeting_.substr(0, greeting_.find('\n')), nullptr, false)},
        {"network_namespace", nsName_},
        {"board_ip", p_.boardIp},
        {"linuxcnc",
         {{"ini", p_.run},
          {"root", o_.linuxcncRoot.empty() ? nlohmann::json(nullptr) : nlohmann::json(o_.linuxcncRoot)}}}};
    const std::string line = ready.dump() + "\n";
    if (::write(o_.readyFd, line.data(), line.size()) != static_cast<ssize_t>(line.size()))
      fmt::print(stderr, "lbpkit linuxcnc: --ready-fd {}: the greeting could not be written\n", o_.readyFd);
    ::close(o_.readyFd);
  }
  return launch;
}

int LinuxCncRun::watch(const LinuxCncLaunch& launch) {
  app::linuxcnc_host::LinuxCncLog log(launch.privateTmp, user_.uid);
  // Its servo thread SCHED_FIFO below the card thread, as on a real-time
  // kernel (linuxcnc/servo_priority.hpp).
  lbpkit::linuxcnc::ServoThreadPriority servoPriority(ns_->inode());
  bool errorWindowShown = false;
  unsigned looks = 0;
  while (true) {
    if (app::gStop) {
      fmt::print("lbpkit linuxcnc: stopping LinuxCNC and the sim\n");
      return 130;
    }
    int status = 0;
    if (::waitpid(lcnc_, &status, WNOHANG) == lcnc_) {
      lcnc_ = -1;
      fmt::print("lbpkit linuxcnc: LinuxCNC {} ({}); stopping the sim\n", WIFEXITED(status) ? "ended" : "was killed",
                 WIFEXITED(status) ? fmt::format("exit status {}", WEXITSTATUS(status))
                                   : fmt::format("signal {}", WTERMSIG(status)));
      if (WIFEXITED(status) && WEXITSTATUS(status) != 0 && WEXITSTATUS(status) != 126) {
        // What LinuxCNC said: its standard output, and its standard
        // error from its own copy in the user's home when it made one.
        log.poll();
        log.printEnd(30, "print");
        if (!printLinuxCncDebugFile(user_, started_)) log.printEnd(30, "debug");
      }
      return WIFEXITED(status) ? WEXITSTATUS(status) : 1;
    }
    if (::waitpid(sim_, &status, WNOHANG) == sim_) {
      sim_ = -1;
      fmt::print(stderr, "lbpkit linuxcnc: lbpkit sim ended ({}); stopping LinuxCNC\n",
                 WIFEXITED(status) ? fmt::format("exit status {}", WEXITSTATUS(status))
                                   : fmt::format("signal {}", WTERMSIG(status)));
      return 1;
    }
    readSim(100);
    log.poll();
    // LinuxCNC that ended with an error at start-up waits in its window
    // (linuxcnc/namespace_processes.hpp) for the user to close it: what it
    // says is printed here too, where the user typed the command, once.
    if (!errorWindowShown && ++looks % 10 == 0 && lbpkit::linuxcnc::errorWindowIsOpen(ns_->inode())) {
      errorWindowShown = true;
      log.poll();
      fmt::print(
          "lbpkit linuxcnc: LinuxCNC ended with an error; its window \"LinuxCNC Errors\" waits on the desktop "
          "(closing it, or Ctrl-C here, ends the run):\n");
      log.printEnd(30, "print");
      log.printEnd(30, "debug");
      std::fflush(stdout);
    }
  }
}

int LinuxCncRun::run() {
  prepare();
  makeNamespace();
  startSim();
  awaitSim();
  return watch(startLinuxCncInRun());
}

int runLinuxCnc(const LinuxCncOptions& o) {
  int exitCode = 0;
  {
    LinuxCncRun run(o);
    exitCode = run.run();
  }
  fmt::print("lbpkit linuxcnc: stopped; the network namespace is removed\n");
  return exitCode;
}

}  // namespace

void addLinuxCncCommand(CLI::App& app) {
  auto o = std::make_shared<LinuxCncOptions>();
  auto* cmd = app.add_subcommand(
      "linuxcnc",
      "Run a LinuxCNC configuration against lbpkit sim (as root): the sim at the configuration's board_ip, LinuxCNC "
      "in a network namespace of its own with its own display; everything stops with it or with Ctrl-C");
  cmd->add_option("config", o->ini, "The configuration's INI file")->required();
  cmd->add_option("--machine", o->machine,
                  "The machine behind the 7I77: auto (the one the configuration expects: lbpkit machine "
                  "--from-config), mill, lathe, gantry or a machine file (lbpkit sim --machine)")
      ->capture_default_str();
  cmd->add_option("--display", o->display,
                  "Run the configuration with this display program in place of its [DISPLAY]DISPLAY (a copy of "
                  "the configuration; for a display of your own or a headless one)");
  cmd->add_option("--card", o->card, "Which Mesa card (default: the one the configuration loads)");
  cmd->add_option("--cpu", o->cpu,
                  "The CPU LinuxCNC and the sim's card thread share, so the card answers before hm2_eth looks "
                  "whatever else runs: a CPU's number, last (the last one lbpkit may use) or any (not pinned)")
      ->capture_default_str();
  cmd->add_option("--ready-fd", o->readyFd,
                  "N: once the sim serves and LinuxCNC has started, write one JSON line to descriptor N (the sim's "
                  "greeting: its addresses and API; the network namespace; the configuration LinuxCNC runs) and "
                  "close it: for a program that drives the run")
      ->check(CLI::Range(0, 1 << 20));
  cmd->add_option("--linuxcnc-root", o->linuxcncRoot,
                  "Run the LinuxCNC installed in this folder (a Debian root with linuxcnc-uspace, such as "
                  "scripts/linuxcnc-releases makes: Debian 13's or unstable's) in place of this PC's; the "
                  "configuration and your home stay where they are");
  cmd->add_flag("--as-written", o->asWritten,
               "Run the configuration untouched and the sim on the wall clock, also on a PC whose kernel is not "
               "real-time (by default there the sim follows LinuxCNC's servo cycles and a copy of the configuration "
               "waits for replies as an on-time servo thread would)");
  cmd->add_option("sim-options", o->simArguments, "After --: more options for lbpkit sim (--clock, --record, ...)");
  cmd->callback([o] { app::gRun = [o] { return runLinuxCnc(*o); }; });
}
