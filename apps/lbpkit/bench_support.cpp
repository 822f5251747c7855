// SPDX-License-Identifier: MIT
// What `lbpkit bench`'s parts start and measure: sims, CPU hogs, programs
// by an argument vector, /proc figures. Every process started here is
// stopped by the object that started it, by its PID.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/utsname.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/core.h>
#include <httplib.h>
#include <nlohmann/json.hpp>

#include <cerrno>
#include <fstream>
#include <thread>

#include "bench.hpp"
#include "common.hpp"
#include "lbpkit/error.hpp"
#include "process/process.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;

namespace lbpkit::app::bench {

using namespace std::chrono_literals;

void checkStop() {
  if (app::gStop.load()) throw lbpkit::Error("interrupted: everything the bench started has been stopped");
}

void sleepFor(std::chrono::duration<double> d) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::nanoseconds>(d);
  while (std::chrono::steady_clock::now() < end) {
    checkStop();
    std::this_thread::sleep_for(std::min<std::chrono::nanoseconds>(end - std::chrono::steady_clock::now(), 50ms));
  }
  checkStop();
}

namespace {

// Waits for a child, through the EINTR of a Ctrl-C (the child got it too).
int reap(pid_t pid) { return lbpkit::process::reap(pid); }

std::string self() {
  std::error_code ec;
  auto p = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) throw lbpkit::Error("cannot find this program's own path (/proc/self/exe) to start sims");
  return p.string();
}

struct Scratch {
  std::filesystem::path dir;
  Scratch() {
    std::string t = (std::filesystem::temp_directory_path() / "lbpkit-bench-XXXXXX").string();
    if (::mkdtemp(t.data()) == nullptr) throw lbpkit::Error("cannot create a scratch folder in the temp directory");
    dir = t;
  }
  ~Scratch() {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
};

}  // namespace

void stopProcess(pid_t pid) { (void)lbpkit::process::stopWithGrace(pid, 3s); }

bool printedSkip(const nlohmann::json& j) {
  if (!j.contains("skipped")) return false;
  fmt::print("  skipped: {}\n\n", j["skipped"].get<std::string>());
  return true;
}

const std::filesystem::path& scratch() {
  static Scratch s;
  return s.dir;
}

Run run(const std::vector<std::string>& argv) {
  Run r;
  if (argv.empty()) return r;
  std::string path = argv.front();
  if (path.find('/') == std::string::npos) {
    const auto found = lbpkit::process::systemProgram(path);
    if (!found) {
      r.out = path + " is not installed";
      return r;
    }
    path = *found;
  }
  static int serial = 0;
  const auto file = scratch() / fmt::format("run-{}", serial++);
  const int out = ::open(file.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (out < 0) throw lbpkit::Error("cannot create a file in the bench's scratch folder");
  // Ready before the fork: the child only redirects and execs.
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(out);
    throw lbpkit::Error("fork failed");
  }
  if (pid == 0) {
    const int null = ::open("/dev/null", O_RDONLY);
    ::dup2(null, 0);
    ::dup2(out, 1);
    ::dup2(out, 2);
    ::execv(path.c_str(), args.data());
    ::_exit(127);
  }
  ::close(out);
  const int status = reap(pid);
  r.exit = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(file);
  r.out.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  std::error_code ec;
  std::filesystem::remove(file, ec);
  return r;
}

std::string installed(const std::string& name) {
  auto path = lbpkit::process::systemProgram(name);
  if (!path) throw lbpkit::Error(name + " is not installed (looked for in the system's folders)");
  return *path;
}

SimProcess::SimProcess(std::vector<std::string> addresses, std::vector<std::string> extra)
    : addresses_(std::move(addresses)) {
  static int serial = 0;
  stateFile_ = scratch() / fmt::format("sim-{}", serial++);
  const bool several = addresses_.size() > 1;
  std::vector<std::string> args = {self(), "sim"};
  for (const auto& a : addresses_) args.insert(args.end(), {"--bind", a});
  args.insert(args.end(), {"--api", "0"});
  // Several cards keep their EEPROMs in a folder of their own.
  args.insert(args.end(), {"--state", several ? stateFile_.string() + ".d" : stateFile_.string()});
  args.insert(args.end(), extra.begin(), extra.end());
  // Serving once it greets on descriptor 3 (lbpkit sim --ready-fd: every
  // card, its control API and web view), with the API's port.
  args.insert(args.end(), {"--ready-fd", "3"});
  int out[2], ready[2];
  if (::pipe2(out, O_CLOEXEC) != 0 || ::pipe2(ready, O_CLOEXEC) != 0) throw lbpkit::Error("pipe failed");
  const auto log = stateFile_.string() + ".log";
  pid_ = ::fork();
  if (pid_ < 0) throw lbpkit::Error("fork failed");
  if (pid_ == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);  // a bench killed outright leaves no sim behind
    const int err = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    ::dup2(out[1], 1);
    ::dup2(err, 2);
    ::dup2(ready[1], 3);
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  ::close(out[1]);
  ::close(ready[1]);
  out_ = out[0];
  std::string text;
  const auto end = std::chrono::steady_clock::now() + 15s;
  while (std::chrono::steady_clock::now() < end && text.find('\n') == std::string::npos) {
    pollfd p{ready[0], POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) {
      if (app::gStop.load()) break;
      continue;
    }
    char buf[1024];
    const ssize_t n = ::read(ready[0], buf, sizeof buf);
    if (n <= 0) break;
    text.append(buf, static_cast<std::size_t>(n));
  }
  ::close(ready[0]);
  const auto greeting = nlohmann::json::parse(text.substr(0, text.find('\n')), nullptr, false);
  if (greeting.is_object() && greeting.contains("cards") && !greeting["cards"].empty() &&
      greeting["cards"][0]["api"].is_object())
    apiPort_ = greeting["cards"][0]["api"]["port"].get<int>();
  if (apiPort_ <= 0) {
    std::ifstream in(log);
    const std::string why((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    stopProcess(pid_);
    pid_ = -1;
    ::close(out_);
    out_ = -1;
    checkStop();
    throw lbpkit::Error(fmt::format("lbpkit sim on {} did not start: {}", addresses_.front(), why.empty() ? text : why));
  }
}

SimProcess::~SimProcess() {
  stopProcess(pid_);
  if (out_ >= 0) ::close(out_);
  for (const char* suffix : {"", ".analog", ".program", ".analog.program", ".flash", ".log"}) {
    std::error_code ec;
    std::filesystem::remove(stateFile_.string() + suffix, ec);
  }
  std::error_code ec;
  std::filesystem::remove_all(stateFile_.string() + ".d", ec);
}

nlohmann::json SimProcess::state() const {
  httplib::Client c(addresses_.size() > 1 ? addresses_.front() : std::string("127.0.0.1"), apiPort_);
  c.set_connection_timeout(2);
  c.set_read_timeout(5);
  auto r = c.Get("/api/state");
  if (!r || r->status != 200) return {};
  return nlohmann::json::parse(r->body, nullptr, false);
}

CpuHog::CpuHog() {
  // One per CPU this process may run on: each keeps one busy.
  const auto n = std::max<std::size_t>(1, lbpkit::process::allowedCpus().size());
  for (std::size_t i = 0; i < n; ++i) {
    const pid_t pid = ::fork();
    if (pid < 0) throw lbpkit::Error("fork failed");
    if (pid == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      volatile std::uint64_t x = 0;
      for (;;) x = x + 1;
    }
    pids_.push_back(pid);
  }
}

CpuHog::~CpuHog() {
  for (const pid_t pid : pids_) ::kill(pid, SIGKILL);
  for (const pid_t pid : pids_) reap(pid);
}

CpuMeter::CpuMeter(std::vector<pid_t> pids) : pids_(std::move(pids)), t0_(std::chrono::steady_clock::now()) {
  for (const pid_t pid : pids_) start_ += cpuSeconds(pid);
}

double CpuMeter::seconds() const {
  double now = 0;
  for (const pid_t pid : pids_) now += cpuSeconds(pid);
  return now - start_;
}

double CpuMeter::wall() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count(); }

double CpuMeter::percent() const {
  const double w = wall();
  return w > 0 ? 100.0 * seconds() / w : 0.0;
}

double cpuSeconds(pid_t pid) {
  // Every thread's time on a CPU in ns (schedstat's first field): exact,
  // where /proc/PID/stat counts in clock ticks.
  double ns = 0;
  bool any = false;
  std::error_code ec;
  for (const auto& task : std::filesystem::directory_iterator(fmt::format("/proc/{}/task", pid), ec)) {
    std::ifstream t(task.path() / "schedstat");
    double run = 0;
    if (t >> run) {
      ns += run;
      any = true;
    }
  }
  if (any) return ns * 1e-9;
  std::ifstream f(fmt::format("/proc/{}/stat", pid));
  std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  // After the command name's closing parenthesis: state is field 3, utime 14, stime 15.
  const auto close = text.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream in(text.substr(close + 2));
  std::string field;
  double ticks = 0;
  for (int i = 3; i <= 15 && in >> field; ++i)
    if (i >= 14) ticks += std::atof(field.c_str());
  return ticks / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

Memory memory(pid_t pid) {
  Memory m;
  auto field = [](const std::string& file, const char* name) {
    std::ifstream f(file);
    std::string line;
    while (std::getline(f, line))
      if (line.rfind(name, 0) == 0) return std::atol(line.c_str() + std::strlen(name));
    return -1L;
  };
  m.rssKb = field(fmt::format("/proc/{}/status", pid), "VmRSS:");
  m.pssKb = field(fmt::format("/proc/{}/smaps_rollup", pid), "Pss:");
  return m;
}

double loadAverage() {
  std::ifstream f("/proc/loadavg");
  double l = 0;
  f >> l;
  return l;
}

nlohmann::json machine() {
  std::string model;
  std::ifstream cpu("/proc/cpuinfo");
  for (std::string line; std::getline(cpu, line);)
    if (line.rfind("model name", 0) == 0) {
      model = line.substr(line.find(':') + 2);
      break;
    }
  utsname u{};
  ::uname(&u);
  return {{"cpu", model},
          {"cpus", std::thread::hardware_concurrency()},
          {"kernel", fmt::format("{} {}", u.sysname, u.release)},
          {"load_average", loadAverage()},
          {"root", ::geteuid() == 0}};
}

}  // namespace lbpkit::app::bench
