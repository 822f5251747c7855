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
// On every way out (LinuxCNC closed or killed, the sim gone, Ctrl-C)
// everything started is stopped and the namespace removed.
#include <fcntl.h>
#include <poll.h>
#include <pwd.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/core.h>

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
#include <vector>

#include "common.hpp"
#include "hostmot2/cards/catalogue.hpp"
#include "lbpkit/error.hpp"
#include "linuxcnc/config_check.hpp"
#include "linuxcnc/network_namespace.hpp"
#include "linuxcnc/servo_priority.hpp"

namespace app {
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
  std::vector<std::string> simArguments;  // after --
};

// A child process: argv run with stdout and stderr into `out` (a pipe's
// write end) or inherited (-1), on `cpu` alone when given (and whatever it
// starts with it). In a process group of its own, so that a terminal's
// Ctrl-C reaches only lbpkit, which stops it in order.
pid_t spawn(const std::vector<std::string>& argv, int out, std::optional<unsigned> cpu = {}) {
  const pid_t pid = ::fork();
  if (pid < 0) throw lbpkit::Error(fmt::format("cannot start {}: fork failed", argv.front()));
  if (pid == 0) {
    ::setpgid(0, 0);
    if (cpu) {
      cpu_set_t set;
      CPU_ZERO(&set);
      CPU_SET(*cpu, &set);
      ::sched_setaffinity(0, sizeof set, &set);
    }
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);  // lbpkit killed outright: its children go too
    if (out >= 0) {
      ::dup2(out, 1);
      ::dup2(out, 2);
    }
    std::vector<char*> args;
    for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    ::execvp(args[0], args.data());
    ::_exit(127);
  }
  ::setpgid(pid, pid);
  return pid;
}

// Stops a child (SIGTERM, then SIGKILL after `grace`) and reaps it: its
// exit status, or -1.
int stop(pid_t pid, std::chrono::milliseconds grace) {
  if (pid <= 0) return -1;
  ::kill(pid, SIGTERM);
  const auto deadline = std::chrono::steady_clock::now() + grace;
  int status = 0;
  while (::waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(-pid, SIGKILL);
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      break;
    }
    std::this_thread::sleep_for(20ms);
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// The PID namespace a process is in (an inode number), or 0.
unsigned long pidNamespace(const std::string& pid) {
  struct stat st {};
  return ::stat(("/proc/" + pid + "/ns/pid").c_str(), &st) == 0 ? static_cast<unsigned long>(st.st_ino) : 0;
}

// Stops LinuxCNC as closing its display does: SIGTERM to every process of
// its PID namespace (the display, whose end the linuxcnc script waits for,
// the task, the servers, rtapi_app) and to the script (unshare's child,
// PID 1 there), whose trap then unloads HAL. If it has not ended in 10 s,
// SIGKILL to unshare, whose --kill-child takes the namespace with it.
int stopLinuxCnc(pid_t unshare) {
  std::ifstream children(fmt::format("/proc/{}/task/{}/children", unshare, unshare));
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
  while (::waitpid(unshare, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline || script <= 0) {
      ::kill(unshare, SIGKILL);
      ::waitpid(unshare, &status, 0);
      break;
    }
    std::this_thread::sleep_for(20ms);
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// The home of the user LinuxCNC runs as: the one who ran sudo (sudo sets
// HOME to root's), or root's own HOME.
std::string linuxCncHome() {
  if (const char* user = std::getenv("SUDO_USER"); user != nullptr && std::string(user) != "root")
    if (const passwd* pw = ::getpwnam(user); pw != nullptr && pw->pw_dir != nullptr) return pw->pw_dir;
  const char* home = std::getenv("HOME");
  return home != nullptr && *home == '/' ? home : "/root";
}

// What LinuxCNC said before it failed: started without a terminal, the
// linuxcnc script writes its messages to linuxcnc_debug.txt in the home of
// the user it runs as.
void printLinuxCncLog() {
  const fs::path log = fs::path(linuxCncHome()) / "linuxcnc_debug.txt";
  std::ifstream in(log);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);)
    if (line.find("Running with fallback_uid") == std::string::npos) lines.push_back(line);
  if (lines.empty()) return;
  fmt::print("lbpkit linuxcnc: the end of LinuxCNC's {}:\n", log.string());
  for (std::size_t i = lines.size() > 12 ? lines.size() - 12 : 0; i < lines.size(); ++i) fmt::print("  {}\n", lines[i]);
}

// The words that run a command with `priv` as its /tmp, in a mount
// namespace of its own (as root, before any change of user): what it needs
// of the PC's /tmp stays there, bound in: the X server's sockets
// (/tmp/.X11-unix, for the user's display) and the folder under /tmp of
// every absolute path in `paths` (the configuration, a display program
// and its files). The command follows these words.
std::vector<std::string> privateTmp(const fs::path& priv, const std::vector<std::string>& paths) {
  fs::create_directories(priv);
  fs::permissions(priv, fs::perms::all | fs::perms::sticky_bit);  // as /tmp: LinuxCNC may run as another user
  std::vector<std::string> keep;
  auto add = [&](const std::string& name) {
    if (!name.empty() && std::find(keep.begin(), keep.end(), name) == keep.end() && fs::exists("/tmp/" + name))
      keep.push_back(name);
  };
  add(".X11-unix");
  for (const auto& text : paths)
    for (auto at = text.find("/tmp/"); at != std::string::npos; at = text.find("/tmp/", at + 1))
      if (at == 0 || text[at - 1] == ' ' || text[at - 1] == '=') {
        const auto name = text.substr(at + 5, text.find_first_of("/ \t", at + 5) - (at + 5));
        add(name);
      }
  std::vector<std::string> argv = {"sh", "-c",
                                   "priv=$1; shift; while [ \"$1\" != -- ]; do mkdir -p \"$priv/$1\" && "
                                   "mount --bind \"/tmp/$1\" \"$priv/$1\" || exit 126; shift; done; shift; "
                                   "mount --rbind \"$priv\" /tmp || exit 126; exec \"$@\"",
                                   "sh", priv.string()};
  argv.insert(argv.end(), keep.begin(), keep.end());
  argv.push_back("--");
  return argv;
}

// The card a board's HAL name is (hm2_7i92.0 -> 7I92), or empty.
std::string cardOfBoard(const std::string& prefix) {
  const auto kind = prefix.substr(4, prefix.find('.') - 4);  // "hm2_7i92.0" -> "7i92"
  for (const auto& card : hm2::cards::all())
    if (card.halName == kind) return std::string(card.name);
  return {};
}

// An address in the card's /24 for LinuxCNC's side: the first from .2 up
// that is not the card's and that this PC does not route yet (another
// lbpkit linuxcnc, with a card in the same /24, has its own); .2 when all are.
std::string peerOf(const std::string& cardIp) {
  const auto dot = cardIp.rfind('.');
  const std::string net = cardIp.substr(0, dot + 1);
  for (int host = 2; host < 255; ++host) {
    const std::string candidate = net + std::to_string(host);
    if (candidate == cardIp) continue;
    FILE* p = ::popen(fmt::format("ip -4 route show exact {}/32 2>/dev/null", candidate).c_str(), "r");
    if (p == nullptr) break;
    char c = 0;
    const bool routed = std::fread(&c, 1, 1, p) == 1;
    ::pclose(p);
    if (!routed) return candidate;
  }
  return net + (cardIp.substr(dot + 1) == "2" ? "3" : "2");
}

// A copy of the configuration in `into`, as LinuxCNC would run it on the
// virtual card: a PCI card's configuration (hm2_pci, a 5I25 or 6I25) on the
// 7I92 at 10.10.10.10 (hm2_eth, its pins hm2_7i92.0.*, no firmware= to
// load), and `display` in place of [DISPLAY]DISPLAY. Returns the copy's INI.
fs::path copyConfiguration(const fs::path& ini, const fs::path& into, const std::vector<std::string>& pciPrefixes,
                           const std::string& display) {
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
  // A configuration older than LinuxCNC 2.8's joints ([EMC]VERSION below
  // 1.1): linuxcnc would ask, in a dialog, to convert it with update_ini;
  // the copy is converted without asking (update_ini -f), as that dialog's
  // "yes" would.
  std::ifstream in(copy);
  std::string line, version;
  bool inEmc = false;
  while (std::getline(in, line)) {
    const auto t = lbpkit::linuxcnc::trim(line);
    if (!t.empty() && t[0] == '[') inEmc = t.rfind("[EMC]", 0) == 0;
    if (inEmc && t.rfind("VERSION", 0) == 0 && t.find('=') != std::string::npos)
      version = lbpkit::linuxcnc::trim(t.substr(t.find('=') + 1));
  }
  double v = 0.0;
  try {
    v = std::stod(version);
  } catch (const std::exception&) {
  }
  if (v < 1.1) {
    fmt::print("lbpkit linuxcnc: {} is a configuration from before LinuxCNC 2.8 ([EMC]VERSION {}): the copy is "
               "converted with update_ini -f, as linuxcnc's own dialog offers\n",
               ini.filename().string(), version.empty() ? "none" : version);
    std::fflush(stdout);
    if (std::system(fmt::format("update_ini -f '{}' >/dev/null 2>&1", copy.string()).c_str()) != 0)
      throw lbpkit::Error(fmt::format("update_ini -f {} failed: LinuxCNC could not convert it either", copy.string()));
  }
  return copy;
}

int runLinuxCnc(const LinuxCncOptions& o) {
  if (::geteuid() != 0)
    throw lbpkit::Error("lbpkit linuxcnc needs root (a network namespace and a veth pair): run it with sudo");
  const fs::path ini = fs::absolute(o.ini);
  if (!fs::is_regular_file(ini)) throw lbpkit::Error(fmt::format("{}: no such configuration file", o.ini));
  for (const char* tool : {"linuxcnc", "ip", "unshare", "setpriv"})
    if (std::system(fmt::format("command -v {} >/dev/null 2>&1", tool).c_str()) != 0)
      throw lbpkit::Error(fmt::format("{} is not installed (linuxcnc-uspace, iproute2, util-linux)", tool));

  // What the configuration loads, checked as lbpkit check-config checks it:
  // LinuxCNC would refuse a configuration with errors.
  const auto result = lbpkit::linuxcnc::checkConfig(ini, app::catalogueBoardModel(o.card, {}));
  unsigned errors = 0;
  for (const auto& f : result.findings)
    if (f.severity == "error") {
      ++errors;
      fmt::print(stderr, "{}:{}: error: {}\n", f.file, f.line, f.reason);
    }
  if (errors > 0)
    throw lbpkit::Error(fmt::format("{}: {} error{} that LinuxCNC would refuse (lbpkit check-config {} says more)",
                                    o.ini, errors, errors == 1 ? "" : "s", o.ini));
  const lbpkit::linuxcnc::Board* board = nullptr;
  std::vector<std::string> pciPrefixes;
  for (const auto& b : result.boards) {
    if (b.driver == "hm2_eth" && board == nullptr) board = &b;
    if (b.driver == "hm2_pci") pciPrefixes.push_back(b.prefix);
  }
  if (board == nullptr && pciPrefixes.empty())
    throw lbpkit::Error(fmt::format("{}: loads no Mesa card (loadrt hm2_eth or hm2_pci)", o.ini));
  if (board != nullptr && board->boardIp.empty())
    throw lbpkit::Error(fmt::format("{}:{}: loadrt hm2_eth has no board_ip=", board->file, board->line));
  // A PCI card cannot be on a veth pair: its configuration runs as the same
  // 7I77 on a 7I92 (Mesa's 7I77x2 firmware has the same modules on both).
  const bool pci = board == nullptr;
  const std::string boardIp = pci ? std::string("10.10.10.10") : board->boardIp;
  const std::string card = !o.card.empty() ? o.card : pci ? std::string("7I92") : cardOfBoard(board->prefix);

  const auto id = std::to_string(::getpid() % 100000);
  // rtapi_app's socket, in LinuxCNC's own /tmp (privateTmp).
  const std::string fifo = "/tmp/rtapi_fifo";
  // What this run makes: the machine file (--machine auto), the copy of a
  // configuration it changes; removed at the end.
  const fs::path runDir = fmt::format("/tmp/lbpkit-linuxcnc-{}", id);
  struct RemoveAll {
    fs::path path;
    ~RemoveAll() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  } removeRunDir{runDir};
  fs::create_directories(runDir);
  std::string machine = o.machine;
  if (machine == "auto") {
    machine = (runDir / "machine.toml").string();
    app::deriveMachineFile(ini, machine, true);
    fmt::print("lbpkit linuxcnc: the machine {} expects (lbpkit machine --from-config {} writes it)\n", o.ini, o.ini);
  }
  fs::path run = ini;
  if (pci || !o.display.empty()) {
    run = copyConfiguration(ini, runDir / "config", pciPrefixes, o.display);
    if (pci)
      fmt::print("lbpkit linuxcnc: {} is a PCI card (hm2_pci): running a copy of the configuration with the same "
                 "7I77 on a 7I92 at 10.10.10.10 (hm2_eth, pins hm2_7i92.0.*) in {}\n",
                 pciPrefixes.front(), run.parent_path().string());
    if (!o.display.empty()) fmt::print("lbpkit linuxcnc: the display is {} ([DISPLAY]DISPLAY in the copy)\n", o.display);
  }

  app::installSignalHandlers();

  const std::string peer = peerOf(boardIp);
  lbpkit::linuxcnc::NetworkNamespace ns(
      "lbpkit-linuxcnc-" + id, {{"lbl" + id, boardIp + "/32", peer + "/24", peer + "/32"}});

  // The sim on the configuration's board_ip, hm2_eth's port, its API and web
  // view on this PC's loopback.
  int pipeFds[2];
  if (::pipe2(pipeFds, O_CLOEXEC) != 0) throw lbpkit::Error("cannot make a pipe for the sim's output");
  std::vector<std::string> simArgv = {"/proc/self/exe", "sim", "--bind", boardIp, "--api", "127.0.0.1:0"};
  if (!card.empty()) simArgv.insert(simArgv.end(), {"--card", card});
  if (!machine.empty()) simArgv.insert(simArgv.end(), {"--machine", machine});
  // LinuxCNC and the card thread on one CPU: each datagram hm2_eth sends
  // wakes the card thread (SCHED_FIFO) on that CPU at once, and the reply is
  // there before hm2_eth looks for it, whatever else the PC runs. hm2_eth's
  // set-up gives each read 1.6 ms (LinuxCNC: hm2_eth.c), mesaflash's
  // discovery 2 ms; a real card answers in microseconds.
  std::optional<unsigned> cpu;
  if (o.cpu == "last") {
    const auto cpus = app::allowedCpus();
    if (!cpus.empty()) cpu = cpus.back();
  } else if (o.cpu != "any") {
    int n = -1;
    try {
      std::size_t used = 0;
      n = std::stoi(o.cpu, &used);
      if (used != o.cpu.size()) n = -1;
    } catch (const std::exception&) {
    }
    if (n < 0) throw lbpkit::Error(fmt::format("--cpu {}: give a CPU's number, last or any", o.cpu));
    cpu = app::checkedCpu(n, "--cpu");
  }
  if (cpu) simArgv.insert(simArgv.end(), {"--cpu", std::to_string(*cpu)});
  simArgv.insert(simArgv.end(), o.simArguments.begin(), o.simArguments.end());
  pid_t sim = spawn(simArgv, pipeFds[1]);
  ::close(pipeFds[1]);
  const int simOut = pipeFds[0];
  std::string simText;
  pid_t lcnc = -1;
  int exitCode = 0;
  auto readSim = [&](int timeoutMs) {
    pollfd p{simOut, POLLIN, 0};
    if (::poll(&p, 1, timeoutMs) <= 0) return false;
    char buf[4096];
    const auto n = ::read(simOut, buf, sizeof buf);
    if (n <= 0) return false;
    const std::string chunk(buf, static_cast<std::size_t>(n));
    simText += chunk;
    fmt::print("{}", chunk);
    std::fflush(stdout);
    return true;
  };
  const auto cleanUp = [&] {
    if (lcnc > 0) stopLinuxCnc(lcnc);
    lcnc = -1;
    if (sim > 0) stop(sim, 10s);
    sim = -1;
    while (readSim(0)) {
    }
    ::close(simOut);
    ns.remove();
  };
  try {
    const auto deadline = std::chrono::steady_clock::now() + 15s;
    while (simText.find("web view: ") == std::string::npos || simText.find('\n', simText.find("web view: ")) == std::string::npos) {
      if (app::gStop || std::chrono::steady_clock::now() > deadline || ::waitpid(sim, nullptr, WNOHANG) == sim) {
        sim = -1;
        throw lbpkit::Error("lbpkit sim did not start (its output is above)");
      }
      readSim(100);
    }

    // LinuxCNC in the namespace, and in PID, IPC and mount namespaces of
    // its own: whatever it starts ends with it, its HAL's shared memory goes
    // with it however it ends (a killed LinuxCNC leaves System V segments
    // behind that the next start trips over), and its /tmp is the run's
    // own, so that the linuxcnc script's lock file (/tmp/linuxcnc.lock)
    // neither stops nor is stopped by another LinuxCNC on this PC.
    std::vector<std::string> argv = {"ip", "netns", "exec", ns.name(), "unshare", "--pid", "--fork",
                                     "--kill-child=SIGKILL", "--mount-proc", "--ipc", "--mount"};
    const auto tmp = privateTmp(runDir / "tmp", {ini.string(), run.string(), o.display});
    argv.insert(argv.end(), tmp.begin(), tmp.end());
    const char* sudoUid = std::getenv("SUDO_UID");
    const char* sudoGid = std::getenv("SUDO_GID");
    if (sudoUid != nullptr && sudoGid != nullptr && std::string(sudoUid) != "0")
      argv.insert(argv.end(), {"setpriv", std::string("--reuid=") + sudoUid, std::string("--regid=") + sudoGid,
                               "--init-groups", "env", "HOME=" + linuxCncHome(), "RTAPI_FIFO_PATH=" + fifo});
    else
      argv.insert(argv.end(), {"env", "RTAPI_UID=65534", "RTAPI_FIFO_PATH=" + fifo});
    argv.insert(argv.end(), {"linuxcnc", run.string()});
    fmt::print("lbpkit linuxcnc: LinuxCNC ({}) in network namespace {}, the card {} at {}{}; Ctrl-C stops both\n",
               run.string(), ns.name(), card, boardIp,
               cpu ? fmt::format(", both on CPU {}", *cpu) : std::string());
    std::fflush(stdout);
    // Its servo thread SCHED_FIFO below the card thread, as on a real-time
    // kernel (linuxcnc/servo_priority.hpp).
    lbpkit::linuxcnc::ServoThreadPriority servoPriority(ns.inode());
    lcnc = spawn(argv, -1, cpu);

    while (true) {
      if (app::gStop) {
        fmt::print("lbpkit linuxcnc: stopping LinuxCNC and the sim\n");
        exitCode = 130;
        break;
      }
      int status = 0;
      if (::waitpid(lcnc, &status, WNOHANG) == lcnc) {
        lcnc = -1;
        exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 1;
        fmt::print("lbpkit linuxcnc: LinuxCNC {} ({}); stopping the sim\n", WIFEXITED(status) ? "ended" : "was killed",
                   WIFEXITED(status) ? fmt::format("exit status {}", WEXITSTATUS(status))
                                     : fmt::format("signal {}", WTERMSIG(status)));
        if (WIFEXITED(status) && WEXITSTATUS(status) != 0) printLinuxCncLog();
        break;
      }
      if (::waitpid(sim, &status, WNOHANG) == sim) {
        sim = -1;
        fmt::print(stderr, "lbpkit linuxcnc: lbpkit sim ended ({}); stopping LinuxCNC\n",
                   WIFEXITED(status) ? fmt::format("exit status {}", WEXITSTATUS(status))
                                     : fmt::format("signal {}", WTERMSIG(status)));
        exitCode = 1;
        break;
      }
      readSim(100);
    }
  } catch (...) {
    cleanUp();
    throw;
  }
  cleanUp();
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
  cmd->add_option("sim-options", o->simArguments, "After --: more options for lbpkit sim (--clock, --record, ...)");
  cmd->callback([o] { app::gRun = [o] { return runLinuxCnc(*o); }; });
}
