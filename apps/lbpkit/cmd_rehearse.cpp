// SPDX-License-Identifier: MIT
// lbpkit rehearse CONFIG.ini: the configuration run as `lbpkit linuxcnc`
// runs it with its defaults (its own child: the same namespace, sim, clock
// and copy), with LinuxCNC's display replaced by a headless driver of
// lbpkit's (rehearse_driver.py, compiled in and written to a folder of
// root's), then worked through the failures the 7I77 manual warns about
// (rehearse.hpp, rehearse_checks.cpp). Each fault is made through the sim's
// control API. The verdicts and figures go to the terminal, report.json and
// report.html in --report DIR (docs/rehearse.md).
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/core.h>
#include <fmt/ranges.h>
#include <httplib.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "common.hpp"
#include "config/machine_toml.hpp"
#include "embedded_text.hpp"
#include "lbpkit/error.hpp"
#include "linuxcnc/hal_config.hpp"
#include "linuxcnc/machine_from_config.hpp"
#include "linuxcnc_run.hpp"
#include "process/process.hpp"
#include "rehearse.hpp"
#include "rehearse_report.hpp"

namespace app = lbpkit::app;
namespace fs = std::filesystem;
using namespace std::chrono_literals;

namespace lbpkit::app::rehearse {

// -- the driver ---------------------------------------------------------

json Driver::readAnswer(std::chrono::milliseconds timeout, const std::string& what) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (true) {
    if (const auto nl = partial_.find('\n'); nl != std::string::npos) {
      auto answer = json::parse(partial_.substr(0, nl), nullptr, false);
      partial_.erase(0, nl + 1);
      if (answer.is_discarded() || !answer.is_object())
        throw lbpkit::Error(fmt::format("the driver in LinuxCNC answered {} with what is not JSON", what));
      if (answer.contains("messages") && answer["messages"].is_array())
        for (const auto& m : answer["messages"])
          if (m.is_string()) messages_.push_back(m.get<std::string>());
      return answer;
    }
    int status = 0;
    if (!ended_ && ::waitpid(run_, &status, WNOHANG) == run_) ended_ = status;
    if (ended_) throw lbpkit::Error(fmt::format("LinuxCNC ended before it answered {}", what));
    if (app::gStop) throw lbpkit::Error("stopped (Ctrl-C)");
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0)
      throw lbpkit::Error(fmt::format("the driver in LinuxCNC did not answer {} within {} s", what,
                                      std::chrono::duration_cast<std::chrono::seconds>(timeout).count()));
    pollfd p{answers_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(std::min<long>(left.count(), 100))) <= 0) continue;
    char buf[65536];
    const ssize_t n = ::read(answers_, buf, sizeof buf);
    if (n > 0) partial_.append(buf, static_cast<std::size_t>(n));
  }
}

json Driver::greeting(std::chrono::milliseconds timeout) { return readAnswer(timeout, "its start"); }

json Driver::ask(const json& request, std::chrono::milliseconds timeout) {
  const std::string line = request.dump() + "\n";
  const std::string what = fmt::format("\"{}\"", request.value("op", std::string("?")));
  for (std::size_t done = 0; done < line.size();) {
    const ssize_t w = ::write(requests_, line.data() + done, line.size() - done);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) throw lbpkit::Error(fmt::format("cannot send {} to the driver: {}", what, std::strerror(errno)));
    done += static_cast<std::size_t>(w);
  }
  return readAnswer(timeout, what);
}

// -- the control API ------------------------------------------------------

namespace {
json answerOf(const httplib::Result& r, const std::string& what) {
  if (!r)
    throw lbpkit::Error(
        fmt::format("{}: the sim's control API did not answer ({})", what, httplib::to_string(r.error())));
  auto j = json::parse(r->body, nullptr, false);
  if (r->status != 200) {
    const std::string why =
        !j.is_discarded() && j.contains("error") && j["error"].is_string() ? j["error"].get<std::string>() : r->body;
    throw lbpkit::Error(fmt::format("{}: {} (HTTP {})", what, why, r->status));
  }
  if (j.is_discarded()) throw lbpkit::Error(fmt::format("{}: the sim's control API answered what is not JSON", what));
  return j;
}
}  // namespace

json Api::get(const std::string& path) const {
  httplib::Client c(host_, port_);
  c.set_connection_timeout(2s);
  c.set_read_timeout(10s);
  return answerOf(c.Get(path), "GET " + path);
}

json Api::post(const std::string& path, const json& body) const {
  httplib::Client c(host_, port_);
  c.set_connection_timeout(2s);
  c.set_read_timeout(10s);
  return answerOf(c.Post(path, body.dump(), "application/json"), "POST " + path + " " + body.dump());
}

const std::vector<double>& Trace::column(const std::string& name) const {
  const auto it = columns.find(name);
  if (it == columns.end()) throw lbpkit::Error(fmt::format("the machine's trace has no column {}", name));
  return it->second;
}

// -- the session ------------------------------------------------------------

void Session::ready() {
  auto st = driver.ask({{"op", "status"}});
  // linuxcnc.STATE_ON is 4.
  if (st.value("task_state", 0) != 4) {
    const auto on = driver.ask({{"op", "machine_on"}});
    if (!on.value("ok", false)) throw lbpkit::Error("LinuxCNC would not turn the machine on: " + on.dump());
    st = driver.ask({{"op", "status"}});
  }
  // The joints not homed: all of them at the start (Home All, as AXIS
  // does), then the one a check's fault left without its position.
  json unhomed = json::array();
  for (std::size_t k = 0; k < st["homed"].size(); ++k)
    if (!st["homed"][k].get<bool>()) unhomed.push_back(k);
  if (!unhomed.empty()) {
    json request = {{"op", "home"}};
    if (unhomed.size() < st["homed"].size()) request["joints"] = unhomed;
    // The driver gives each joint its search across the travel
    // (rehearse_driver.py: home_time), at most ten minutes a joint.
    const auto h = driver.ask(request, std::chrono::seconds(600 * (unhomed.size() + 1)));
    if (!h.value("ok", false)) throw lbpkit::Error("LinuxCNC did not home every joint: " + h.dump());
  }
}

bool Session::mdi(const std::string& command, double timeoutS) {
  return driver
      .ask({{"op", "mdi"}, {"command", command}, {"timeout", timeoutS}},
           std::chrono::milliseconds(static_cast<long>(timeoutS * 1000) + 10'000))
      .value("ok", false);
}

bool Session::wanted(const std::string& id) const { return wantedBy(only, id); }

bool wantedBy(const std::vector<std::string>& only, const std::string& id) {
  if (only.empty()) return true;
  // One is the other's beginning, at a dot or the end: "runaway" asks for
  // "runaway.x..." and "runaway.x.jammed.moving" for the group "runaway.x".
  auto begins = [](const std::string& whole, const std::string& part) {
    return whole.compare(0, part.size(), part) == 0 && (whole.size() == part.size() || whole[part.size()] == '.');
  };
  return std::any_of(only.begin(), only.end(), [&](const std::string& o) { return begins(id, o) || begins(o, id); });
}

Trace Session::trace(double sinceS) const {
  const auto j = api.get(fmt::format("/api/machine/trace?since={:.6f}", sinceS));
  Trace t;
  const auto& names = j.at("columns");
  for (std::size_t c = 0; c < names.size(); ++c) {
    auto& column = t.columns[names[c].get<std::string>()];
    column.reserve(j.at("rows").size());
    for (const auto& row : j.at("rows")) column.push_back(row.at(c).is_number() ? row.at(c).get<double>() : 0.0);
  }
  return t;
}

}  // namespace lbpkit::app::rehearse

namespace {

using lbpkit::app::rehearse::json;
namespace rehearse = lbpkit::app::rehearse;

struct RehearseOptions {
  std::string ini;
  std::string machine = "auto";
  std::string card;  // lbpkit linuxcnc's --card
  std::string report;
  std::string only;
};

// A descriptor closed when it goes.
struct Fd {
  int fd = -1;
  Fd() = default;
  explicit Fd(int f) : fd(f) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

// A file `path` written whole with `text`, made new (a link there is
// refused, never followed), then given to `owner`.
void writeFile(const fs::path& path, const std::string& text, const app::linuxcnc_run::RunAs& owner, mode_t mode) {
  ::unlink(path.c_str());  // an earlier report's: the folder is the user's, checked below
  Fd f(::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, mode));
  if (f.fd < 0) throw lbpkit::Error(fmt::format("cannot write {}: {}", path.string(), std::strerror(errno)));
  if (::write(f.fd, text.data(), text.size()) != static_cast<ssize_t>(text.size()))
    throw lbpkit::Error(fmt::format("cannot write {}: {}", path.string(), std::strerror(errno)));
  if (::fchown(f.fd, owner.uid, owner.gid) != 0 || ::fchmod(f.fd, mode) != 0)
    throw lbpkit::Error(fmt::format("cannot give {} to {}: {}", path.string(), owner.name, std::strerror(errno)));
}

// The report's folder: made for the user, or theirs already (a link, or a
// folder another user owns, is refused: root writes into it).
fs::path reportFolder(const RehearseOptions& o, const app::linuxcnc_run::RunAs& user) {
  const fs::path dir = fs::absolute(o.report.empty() ? "rehearse-" + fs::path(o.ini).stem().string() : o.report);
  struct stat st {};
  if (::lstat(dir.c_str(), &st) != 0) {
    if (::mkdir(dir.c_str(), 0755) != 0)
      throw lbpkit::Error(fmt::format("--report {}: cannot make it: {}", dir.string(), std::strerror(errno)));
    if (::chown(dir.c_str(), user.uid, user.gid) != 0)
      throw lbpkit::Error(fmt::format("--report {}: cannot give it to {}", dir.string(), user.name));
    return dir;
  }
  if (!S_ISDIR(st.st_mode))
    throw lbpkit::Error(
        fmt::format("--report {}: is not a folder (a link or a file is never written through)", dir.string()));
  if (st.st_uid != user.uid && st.st_uid != 0)
    throw lbpkit::Error(fmt::format("--report {}: belongs to another user", dir.string()));
  return dir;
}

// The driver's folder under /tmp (LinuxCNC's own /tmp binds it in, as it
// does every /tmp folder its display's command names): root's, mode 0711;
// the driver root's and read-only; the two FIFOs the user's, 0600.
class DriverFolder {
 public:
  explicit DriverFolder(const app::linuxcnc_run::RunAs& user) {
    char tmpl[] = "/tmp/lbpkit-rehearse-XXXXXX";
    if (::mkdtemp(tmpl) == nullptr)
      throw lbpkit::Error(fmt::format("cannot make a folder in /tmp: {}", std::strerror(errno)));
    path_ = tmpl;
    ::chmod(path_.c_str(), 0711);
    app::linuxcnc_run::RunAs root;
    writeFile(driver(), std::string(app::rehearseDriverSource()), root, 0755);
    for (const auto& fifo : {requests(), answers()}) {
      if (::mkfifo(fifo.c_str(), 0600) != 0 || ::chown(fifo.c_str(), user.uid, user.gid) != 0)
        throw lbpkit::Error(fmt::format("cannot make {}: {}", fifo.string(), std::strerror(errno)));
    }
  }
  ~DriverFolder() { app::linuxcnc_run::removeTree(path_); }
  DriverFolder(const DriverFolder&) = delete;
  DriverFolder& operator=(const DriverFolder&) = delete;
  [[nodiscard]] fs::path driver() const { return path_ / "rehearse_driver.py"; }
  [[nodiscard]] fs::path requests() const { return path_ / "requests"; }
  [[nodiscard]] fs::path answers() const { return path_ / "answers"; }

 private:
  fs::path path_;
};

// The configuration's own hm2 watchdog (a setp of NAME.watchdog.timeout_ns
// in its HAL files), before lbpkit linuxcnc's copy raises it for a PC
// without a real-time kernel.
std::optional<long> configuredWatchdog(const std::string& ini) {
  std::vector<lbpkit::linuxcnc::Finding> findings;
  const auto hal = lbpkit::linuxcnc::readConfiguration(ini, findings);
  for (const auto& s : hal.setps) {
    const std::string suffix = ".watchdog.timeout_ns";
    if (s.name.size() > suffix.size() && s.name.compare(s.name.size() - suffix.size(), suffix.size(), suffix) == 0) {
      try {
        return std::stol(s.value);
      } catch (const std::exception&) {
      }
    }
  }
  return std::nullopt;
}

// The words of a comma-separated list.
std::vector<std::string> words(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string w; std::getline(in, w, ',');)
    if (!w.empty()) out.push_back(w);
  return out;
}

// What one rehearsal needs from the command line and the configuration.
struct Context {
  const RehearseOptions& options;
  app::linuxcnc_run::RunAs user;
  fs::path ini, report, machinePath, logPath;
  lbpkit::model::machine::MachineDescription machine;
  std::vector<std::string> only;
};

using Check = void (*)(rehearse::Session&, rehearse::Results&);

// What a LinuxCNC session of the rehearsal left besides its results.
struct Outcome {
  std::string failure;   // why it stopped before its last check; empty: it did not
  json clock = nullptr;  // the sim's clock at its end (/api/state)
  std::string units;
  std::vector<std::string> said;  // what LinuxCNC said
};

// The last 25 lines of lbpkit linuxcnc's output.
std::string tail(const fs::path& logPath) {
  std::ifstream in(logPath);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  std::string out;
  for (std::size_t i = lines.size() > 25 ? lines.size() - 25 : 0; i < lines.size(); ++i)
    out += "  | " + lines[i] + "\n";
  return out;
}

// One LinuxCNC session: lbpkit linuxcnc started with the driver as its
// display, `checks` run in it (those --only asks for), LinuxCNC stopped.
Outcome rehearseIn(const Context& c, std::span<const std::pair<const char*, Check>> checks,
                   rehearse::Results& results) {
  DriverFolder folder(c.user);
  const auto& logPath = c.logPath;
  const auto& ini = c.ini;
  const auto& machinePath = c.machinePath;
  const auto& o = c.options;
  Fd log(::open(logPath.c_str(), O_WRONLY | O_APPEND | O_NOFOLLOW | O_CLOEXEC));
  int readyPipe[2];
  if (::pipe2(readyPipe, O_CLOEXEC) != 0) throw lbpkit::Error("cannot make a pipe");
  Fd readyRead(readyPipe[0]), readyWrite(readyPipe[1]);

  const std::string display = fmt::format("{} --requests {} --answers {}", folder.driver().string(),
                                          folder.requests().string(), folder.answers().string());
  const std::string self = fs::read_symlink("/proc/self/exe").string();
  lbpkit::process::SpawnOptions so;
  so.out = log.fd;
  so.ready = readyWrite.fd;
  so.ownProcessGroup = true;
  so.deathSignal = SIGTERM;
  std::vector<std::string> argv = {self,        "linuxcnc", ini.string(), "--machine", machinePath.string(),
                                   "--display", display,    "--ready-fd", "3"};
  if (!o.card.empty()) argv.insert(argv.end(), {"--card", o.card});
  const pid_t runPid = lbpkit::process::spawn(argv, so);
  ::close(readyWrite.fd);
  readyWrite.fd = -1;

  // Whatever happens below, the run is stopped as Ctrl-C would stop it.
  struct Stopper {
    pid_t pid;
    bool reaped = false;
    ~Stopper() {
      if (!reaped) lbpkit::process::stopWithGrace(pid, 30s, SIGINT, true);
    }
  } stopper{runPid};

  // The run's greeting: the sim's API and the namespace.
  std::string greeting;
  const auto until = std::chrono::steady_clock::now() + 180s;
  while (greeting.find('\n') == std::string::npos) {
    int status = 0;
    if (::waitpid(runPid, &status, WNOHANG) == runPid) {
      stopper.reaped = true;
      throw lbpkit::Error(fmt::format("lbpkit linuxcnc ended before LinuxCNC started; the end of {}:\n{}",
                                      logPath.string(), tail(logPath)));
    }
    if (app::gStop || std::chrono::steady_clock::now() > until)
      throw lbpkit::Error(app::gStop ? "stopped (Ctrl-C)" : "LinuxCNC did not start within 180 s");
    pollfd p{readyRead.fd, POLLIN, 0};
    if (::poll(&p, 1, 200) > 0) {
      char buf[4096];
      const ssize_t n = ::read(readyRead.fd, buf, sizeof buf);
      if (n > 0) greeting.append(buf, static_cast<std::size_t>(n));
    }
  }
  const auto g = json::parse(greeting.substr(0, greeting.find('\n')), nullptr, false);
  if (g.is_discarded()) throw lbpkit::Error("lbpkit linuxcnc's greeting is not JSON");
  const std::string url = g["sim"]["cards"][0]["api"]["url"].get<std::string>();
  const auto address = app::parseApiAddress(url.substr(url.find("//") + 2), "127.0.0.1");
  rehearse::Api api(address.host, address.port);

  Fd answers(::open(folder.answers().c_str(), O_RDWR | O_CLOEXEC));
  Fd requests(::open(folder.requests().c_str(), O_RDWR | O_CLOEXEC));
  rehearse::Driver driver(requests.fd, answers.fd, runPid);
  try {
    driver.greeting(120s);
  } catch (const lbpkit::Error& e) {
    if (driver.ended()) stopper.reaped = true;
    throw lbpkit::Error(fmt::format("{}; the end of {}:\n{}", e.what(), logPath.string(), tail(logPath)));
  }
  const auto described = driver.ask({{"op", "describe"}});

  rehearse::Session s{driver,
                      api,
                      c.machine,
                      {},
                      described.value("linear_units", std::string("mm")),
                      ini.string(),
                      g.value("network_namespace", std::string()),
                      configuredWatchdog(ini.string()),
                      {},
                      0.0,
                      c.only};
  if (described.contains("spindle_max_rpm") && described["spindle_max_rpm"].is_number())
    s.spindleMaxRpm = described["spindle_max_rpm"].get<double>();
  if (described.contains("default_jog_velocity") && described["default_jog_velocity"].is_number())
    s.jogVelocity = described["default_jog_velocity"].get<double>();
  for (const auto& [name, value] : described["params"].items())
    if (name.size() > 20 && name.compare(name.size() - 20, 20, ".watchdog.timeout_ns") == 0)
      s.watchdogParameters.push_back(name);
  for (const auto& j : described["joints"]) {
    rehearse::Joint joint;
    joint.joint = j["joint"].get<unsigned>();
    joint.letter = j["letter"].get<std::string>().at(0);
    auto number = [&](const char* key, double otherwise) {
      return j[key].is_number() ? j[key].get<double>() : otherwise;
    };
    joint.ferror = number("ferror", 1.0);
    joint.minFerror = number("min_ferror", joint.ferror);
    joint.maxVelocity = number("max_velocity", 0.0);
    joint.maxAcceleration = number("max_acceleration", 0.0);
    joint.minLimit = number("min_limit", -1e9);
    joint.maxLimit = number("max_limit", 1e9);
    joint.home = number("home", 0.0);
    const std::string axisName(1, static_cast<char>(std::tolower(static_cast<unsigned char>(joint.letter))));
    for (const auto& a : c.machine.axes)
      if (a.name == axisName) {
        joint.axis = a.name;
        joint.servo = !a.drives.empty() && !a.stepper;
        // One count of LinuxCNC's feedback: the encoder's where the INI
        // has one (a servo, or a stepper closed through an encoder), else
        // the step; the coarser where it gives both.
        for (const char* key : {"encoder_scale", "step_scale"})
          if (const double scale = number(key, 0.0); scale != 0.0)
            joint.count = std::max(joint.count, 1.0 / std::abs(scale));
        joint.hardStopMin = a.travelMin - a.overtravel;
        joint.hardStopMax = a.travelMax + a.overtravel;
      }
    s.joints.push_back(joint);
  }

  const auto wanted = [&](const std::string& name) { return s.wanted(name); };
  auto show = [&](std::size_t from) {
    for (std::size_t i = from; i < results.size(); ++i) fmt::print("  {}\n", rehearse::checkLine(results[i], s.units));
    std::fflush(stdout);
  };
  const auto start = driver.ask({{"op", "start"}}, 60s);
  if (!start.value("ok", false))
    throw lbpkit::Error(fmt::format("LinuxCNC would not leave E-stop and turn the machine on: {}", start.dump()));
  s.ready();
  Outcome out;
  try {
    for (const auto& [name, check] : checks) {
      if (!wanted(name)) continue;
      const auto n = results.size();
      check(s, results);
      show(n);
    }
  } catch (const lbpkit::Error& e) {
    out.failure = e.what();
  }
  // How the sim's clock followed LinuxCNC's servo thread over the
  // rehearsal: its silences (a servo thread held back past 40 ms meets the
  // 7I77's own watchdog: docs/clocks.md) and the times the card was held
  // back.
  try {
    out.clock = api.get("/api/state").at("clock");
  } catch (const std::exception&) {
  }
  if (!driver.ended()) {
    try {
      driver.ask({{"op", "quit"}}, 10s);
    } catch (const lbpkit::Error&) {
    }
  }
  stopper.reaped = true;
  lbpkit::process::stopWithGrace(runPid, 30s, SIGINT, true);
  out.units = s.units;
  out.said = driver.messages();
  return out;
}

int run(const RehearseOptions& o) {
  if (::geteuid() != 0)
    throw lbpkit::Error(
        "lbpkit rehearse runs LinuxCNC as lbpkit linuxcnc does, in a network namespace of its own: "
        "run it with sudo");
  const auto only = words(o.only);
  for (const auto& name : only) {
    const auto first = name.substr(0, name.find('.'));
    if (std::find(rehearse::checkNames().begin(), rehearse::checkNames().end(), first) == rehearse::checkNames().end())
      throw lbpkit::Error(
          fmt::format("--only: no check \"{}\" (there are {}, and the ids in report.json: "
                      "runaway.x, runaway.x.reversed-encoder.moving, ...)",
                      name, fmt::join(rehearse::checkNames(), ", ")));
  }
  const auto user = app::linuxcnc_run::invokingUser();
  const fs::path ini = fs::absolute(o.ini);
  if (!fs::is_regular_file(ini)) throw lbpkit::Error(fmt::format("{}: no such configuration", o.ini));
  const auto report = reportFolder(o, user);

  // The machine: the one lbpkit linuxcnc would derive, written where the
  // report is, or the user's.
  fs::path machinePath = o.machine;
  if (o.machine == "auto") {
    const auto derived = lbpkit::linuxcnc::machineFromConfig(ini);
    if (!derived.ok()) {
      for (const auto& f : derived.findings)
        if (f.severity == "error") fmt::print(stderr, "{}:{}: error: {}\n", f.file, f.line, f.reason);
      throw lbpkit::Error(fmt::format("no machine could be derived from {} (above)", o.ini));
    }
    machinePath = report / "machine.toml";
    writeFile(machinePath, derived.toml, user, 0644);
  }
  auto machine = lbpkit::config::loadMachineFile(machinePath.string());
  const auto logPath = report / "linuxcnc.log";
  writeFile(logPath, "", user, 0644);
  const Context c{o, user, ini, report, machinePath, logPath, machine, only};
  fmt::print("lbpkit rehearse: {} through lbpkit linuxcnc (its output: {}), the machine {}\n", o.ini, logPath.string(),
             machinePath.string());
  std::fflush(stdout);

  // The checks, in checkNames()'s order, in four LinuxCNC sessions: the
  // field power's may leave LinuxCNC's smart-serial port unusable, a
  // network cut lets the 7I77's watchdog bite, and a stopped host is
  // LinuxCNC's real-time part stopped; each of those starts from a
  // LinuxCNC of its own.
  const std::vector<std::vector<std::pair<const char*, Check>>> sessions = {
      {{"runaway", rehearse::runaway},
       {"estop", rehearse::estopChain},
       {"limits", rehearse::limits},
       {"spindle", rehearse::spindle}},
      {{"field", rehearse::fieldPower}},
      {{"host.network", rehearse::networkCut}},
      {{"host.stopped", rehearse::losingTheHost}}};
  rehearse::Results results;
  std::string failure;
  json clock = nullptr;
  std::string units = "mm";
  std::vector<std::string> said;
  for (const auto& checks : sessions) {
    if (!std::any_of(checks.begin(), checks.end(), [&](const auto& k) { return rehearse::wantedBy(only, k.first); }))
      continue;
    const auto outcome = rehearseIn(c, checks, results);
    units = outcome.units;
    clock = outcome.clock;
    said.insert(said.end(), outcome.said.begin(), outcome.said.end());
    if (!outcome.failure.empty()) {
      failure = outcome.failure;
      break;
    }
  }

  bool failed = !failure.empty();
  for (const auto& r : results) failed = failed || r.value("verdict", std::string()) == "fail";
  json doc = {
      {"lbpkit", "rehearse"},
      {"configuration", ini.string()},
      {"machine", o.machine == "auto" ? machine.name + " (derived from the configuration)" : machinePath.string()},
      {"linear_units", units},
      {"verdict", failed ? "fail" : "pass"},
      {"checks", results},
      {"linuxcnc_said", said},
      {"sim_clock", clock}};
  if (!failure.empty()) doc["stopped"] = failure;
  writeFile(report / "report.json", doc.dump(2) + "\n", user, 0644);
  writeFile(report / "report.html", rehearse::reportHtml(doc), user, 0644);
  if (!failure.empty())
    fmt::print(stderr, "lbpkit rehearse: stopped before the end: {}; the end of {}:\n{}", failure, logPath.string(),
               tail(logPath));
  fmt::print("lbpkit rehearse: {}: {} (report: {}, {})\n", o.ini, failed ? "FAIL" : "pass",
             (report / "report.html").string(), (report / "report.json").string());
  return failed ? 1 : 0;
}

}  // namespace

void addRehearseCommand(CLI::App& app) {
  auto o = std::make_shared<RehearseOptions>();
  auto* cmd = app.add_subcommand(
      "rehearse",
      "Rehearse what the 7I77 manual warns about (a runaway, the E-stop chain, limits, field power, the "
      "spindle, a dead host or network) against a LinuxCNC configuration before power-on (needs root)");
  cmd->add_option("config", o->ini, "The configuration's INI file")->required();
  cmd->add_option("--machine", o->machine,
                  "auto (derived from the configuration, as lbpkit linuxcnc does) or a machine file")
      ->capture_default_str();
  cmd->add_option("--card", o->card,
                  "The card lbpkit linuxcnc's sim is (as its --card: 7I92T for a 7I77 and a 7I76); by default the "
                  "one the configuration's hm2_eth names");
  cmd->add_option("--report", o->report, "Where report.json and report.html go (default: rehearse-<INI name> here)");
  cmd->add_option("--only", o->only,
                  "Only these checks, comma-separated: runaway, estop, limits, spindle, field, host, or the start "
                  "of a check's id in report.json (runaway.x, runaway.x.reversed-encoder.moving, host.network)");
  cmd->callback([o] {
    app::gRun = [o] {
      app::installSignalHandlers();
      return run(*o);
    };
  });
}
