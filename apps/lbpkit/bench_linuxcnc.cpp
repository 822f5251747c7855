// SPDX-License-Identifier: MIT
// `lbpkit bench --only network,discovery`: LinuxCNC's hm2_eth against
// `lbpkit sim`, as the interop tests run it (tests/interop_test.cpp):
// LinuxCNC in a network namespace joined by a veth pair to the root
// namespace, where the sim answers (Debian's hm2_eth cannot use loopback).
//
// network: the servo thread at 1, 2, 4 and 10 kHz, idle and beside a CPU hog
// at normal priority; what hm2_eth counted (packet errors, io_error), what the
// sim measured of itself (server time, wake-up latency), and LinuxCNC's own
// lateness (its servo thread's scheduling error, timedelta(9)), so a miss is
// put where it happened.
// discovery: DOITs (counted by the sim) and wall time of lbpkit's discovery
// to its first normal cycle against LinuxCNC's `loadrt hm2_eth`, on the
// same sim and link.
#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <unistd.h>

#include <fmt/core.h>

#include <cmath>
#include <fstream>
#include <optional>
#include <thread>

#include "bench.hpp"
#include "lbpkit/error.hpp"
#include "lbpkit/lbp16_transport.hpp"
#include "lbpkit/sserial.hpp"
#include "linuxcnc/network_namespace.hpp"
#include "process/process.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;

namespace lbpkit::app::bench {
namespace {

using nlohmann::json;

// Why LinuxCNC cannot be run here, or nothing.
std::optional<std::string> unavailable() {
  if (::geteuid() != 0) return "needs root (network namespaces, a veth pair): run `sudo lbpkit bench`";
  using lbpkit::process::systemProgram;
  if (!systemProgram("halcmd") || !systemProgram("halrun") || !systemProgram("ip"))
    return "LinuxCNC (linuxcnc-uspace: halcmd, halrun) or iproute2 (ip) is not installed";
  return std::nullopt;
}

// The namespace, the veth pair, and whatever LinuxCNC runs in it, all gone
// with the object.
class LinuxCncLink {
 public:
  LinuxCncLink() {
    const auto id = std::to_string(::getpid() % 100000);
    const auto net = fmt::format("10.212.{}.", ::getpid() % 250);
    cardIp_ = net + "1";
    // Not in the scratch folder: rtapi_app runs as RTAPI_UID and makes its socket here.
    fifo_ = (std::filesystem::temp_directory_path() / ("lbpkit-bench-rtapi-" + id)).string();
    // What runs inside, by absolute path: `ip netns exec`, env and timeout
    // would otherwise each look the next program up in a PATH. LinuxCNC's
    // own scripts (halrun) get the system's folders as theirs.
    inside_ = {installed("env")};
    for (auto& setting : lbpkit::linuxcnc::rtapiSettings(fifo_)) inside_.push_back(std::move(setting));
    std::string path;
    for (const auto folder : lbpkit::process::kSystemFolders) path += (path.empty() ? "" : ":") + std::string(folder);
    inside_.insert(inside_.end(), {"PATH=" + path, installed("timeout"), "60"});
    halcmd_ = installed("halcmd");
    halrun_ = installed("halrun");
    ns_.emplace("lbpkit-bench-" + id,
                std::vector<lbpkit::linuxcnc::VethLink>{{"lbb" + id, cardIp_ + "/24", net + "2/24", {}}});
  }
  ~LinuxCncLink() { cleanUp(); }
  LinuxCncLink(const LinuxCncLink&) = delete;
  LinuxCncLink& operator=(const LinuxCncLink&) = delete;

  // `halcmd ARGS` in the namespace, each argument one word as halcmd gets
  // it. rtapi_app, started by the first one, inherits its priority: the
  // normal one.
  Run halcmd(const std::vector<std::string>& args) { return inside(halcmd_, args); }
  std::string getp(const std::string& pin) {
    auto v = halcmd({"getp", pin}).out;
    while (!v.empty() && (v.back() == '\n' || v.back() == ' ')) v.pop_back();
    return v;
  }
  // Unloads everything; rtapi_app exits.
  void unload() { (void)inside(halrun_, {"-U"}); }
  [[nodiscard]] const std::string& cardIp() const { return cardIp_; }
  [[nodiscard]] const std::string& ns() const { return ns_->name(); }
  // The scheduling policy of rtapi_app's threads (the best of them).
  std::string rtapiScheduling() {
    std::string best = "not running";
    for (const auto& pidText : pids()) {
      const int pid = std::atoi(pidText.c_str());
      std::ifstream comm(fmt::format("/proc/{}/comm", pid));
      std::string name;
      comm >> name;
      if (name != "rtapi_app") continue;
      best = "SCHED_OTHER";
      std::error_code ec;
      for (const auto& task : std::filesystem::directory_iterator(fmt::format("/proc/{}/task", pid), ec)) {
        const int policy = ::sched_getscheduler(std::atoi(task.path().filename().c_str()));
        if (policy == SCHED_FIFO) return "SCHED_FIFO";
        if (policy == SCHED_RR) best = "SCHED_RR";
      }
    }
    return best;
  }

 private:
  // `program ARGS` in the namespace, with LinuxCNC's environment, stopped
  // after 60 s.
  Run inside(const std::string& program, const std::vector<std::string>& args) {
    auto argv = ns_->execArgv();
    argv.insert(argv.end(), inside_.begin(), inside_.end());
    argv.push_back(program);
    argv.insert(argv.end(), args.begin(), args.end());
    return run(argv);
  }
  // The PIDs of the processes in the namespace (`ip netns pids`).
  std::vector<std::string> pids() const {
    std::vector<std::string> out;
    std::istringstream in(lbpkit::process::runProgram({"ip", "netns", "pids", ns_->name()}).output);
    for (std::string w; in >> w;) out.push_back(w);
    return out;
  }
  void cleanUp() {
    if (!ns_) return;
    unload();
    // Whatever still runs in the namespace was started by this bench
    // (rtapi_app, halcmd): by its PID.
    for (const auto& pid : pids()) ::kill(std::atoi(pid.c_str()), SIGKILL);
    ns_.reset();
    std::error_code ec;
    std::filesystem::remove(fifo_, ec);
  }

  std::optional<lbpkit::linuxcnc::NetworkNamespace> ns_;
  std::string cardIp_, fifo_;
  std::vector<std::string> inside_;  // env, LinuxCNC's settings, timeout 60
  std::string halcmd_, halrun_;
};

double number(const json& j, const char* key) { return j.contains(key) && j[key].is_number() ? j[key].get<double>() : NAN; }

// One point: the servo thread at `rate` Hz for `seconds`, the sim started
// with `variant` (a row name, "-" for the sim as it is, and its options).
json networkPoint(LinuxCncLink& link, unsigned rate, double seconds, const char* load,
                  const std::pair<std::string, std::vector<std::string>>& variant = {"-", {}}) {
  SimProcess sim(link.cardIp(), variant.second);
  const auto period = 1'000'000'000U / rate;
  const auto file = (scratch() / "bench.hal").string();
  // timedelta first in the thread: its figures are the thread's wake-ups,
  // not hm2_eth's waits for replies.
  std::ofstream(file) << "loadrt hostmot2\n"
                      << "loadrt hm2_eth board_ip=" << link.cardIp()
                      << " config=\"num_encoders=6 sserial_port_0=00xxxx\"\n"
                      << "loadrt threads name1=servo period1=" << period << "\n"
                      << "loadrt timedelta count=1\n"
                      << "addf timedelta.0 servo\naddf hm2_7i92.0.read servo\naddf hm2_7i92.0.write servo\nstart\n";
  json p{{"rate_hz", rate}, {"load", load}, {"seconds", seconds}, {"variant", variant.first}};
  const auto r = link.halcmd({"-f", file});
  std::filesystem::remove(file);
  if (r.exit != 0) {
    link.unload();
    // What hm2_eth said (LinuxCNC's own start-up chatter left out).
    std::string said;
    std::istringstream in(r.out);
    for (std::string line; std::getline(in, line);)
      if (line.find("hm2") != std::string::npos && line.find("bench.hal") == std::string::npos)
        said += (said.empty() ? "" : "; ") + line;
    p["error"] = "hm2_eth did not load: " + (said.empty() ? r.out : said);
    return p;
  }
  // Errors and the sim's figures count from the load, as a user sees them;
  // the servo thread's wake-up error from after its first cycles (the load
  // itself holds it up once).
  const auto loaded = std::chrono::steady_clock::now();
  const CpuMeter simCpu({sim.pid()});
  sleepFor(std::chrono::milliseconds(300));
  const std::string board = "hm2_7i92.0.";
  (void)link.halcmd({"setp", "timedelta.0.reset", "1"});
  (void)link.halcmd({"setp", "timedelta.0.reset", "0"});
  sleepFor(std::chrono::duration<double>(seconds) - (std::chrono::steady_clock::now() - loaded));
  const auto errors = std::atoll(link.getp(board + "packet-error-total").c_str());
  const auto ioError = link.getp(board + "io_error");
  const auto jitter = std::atof(link.getp("timedelta.0.jitter").c_str());
  const auto maxGap = std::atof(link.getp("timedelta.0.max").c_str());
  const auto scheduling = link.rtapiScheduling();
  const auto s1 = sim.state();
  const double simCpuPercent = simCpu.percent();
  link.unload();
  const auto& server = s1["server"];
  const double timeoutUs = 0.8 * period / 1000.0;  // hm2_eth's read timeout: 80 % of the period
  std::uint64_t slow = 0;
  if (server.contains("at_least_us")) {
    // The listed threshold nearest below the timeout (exact at 1, 2, 4, 10 kHz).
    unsigned best = 0;
    for (const auto& [k, v] : server["at_least_us"].items())
      if (const unsigned t = static_cast<unsigned>(std::atoi(k.c_str())); t <= timeoutUs + 0.5 && t >= best) {
        best = t;
        slow = v.get<std::uint64_t>();
      }
    p["sim_slow_threshold_us"] = best;
  }
  p["datagrams"] = s1["lbp16"]["packets"].get<std::uint64_t>();
  p["packet_errors"] = errors;
  p["io_error"] = ioError == "TRUE";
  p["read_timeout_us"] = timeoutUs;
  p["sim"] = {{"scheduling", server["scheduling"]},
              {"server_us",
               {{"median", number(server, "median_us")},
                {"p99", number(server, "p99_us")},
                {"p999", number(server, "p999_us")},
                {"max", number(server, "max_us")}}},
              {"wake_us",
               {{"median", number(server, "queue_median_us")},
                {"p99", number(server, "queue_p99_us")},
                {"p999", number(server, "queue_p999_us")},
                {"max", number(server, "queue_max_us")}}},
              {"slower_than_timeout", slow},
              {"cpu_percent", simCpuPercent},
              {"datagrams_measured", server["datagrams"]}};
  p["linuxcnc"] = {{"scheduling", scheduling},
                   {"worst_wake_error_us", jitter / 1000.0},
                   {"longest_period_us", maxGap / 1000.0}};
  // Whose misses: the sim's slow replies bound its share of the errors.
  std::string verdict;
  if (errors == 0 && ioError != "TRUE")
    verdict = "clean";
  else if (slow == 0)
    verdict = fmt::format("every reply left the sim within {:.0f} us: the misses are LinuxCNC's (servo thread {}, "
                          "worst wake-up error {:.0f} us) or the kernel's",
                          timeoutUs, scheduling, jitter / 1000.0);
  else
    verdict = fmt::format("{} datagrams took the sim {:.0f} us or more (its share, at most); the rest are LinuxCNC's "
                          "(servo thread {}, worst wake-up error {:.0f} us) or the kernel's",
                          slow, timeoutUs, scheduling, jitter / 1000.0);
  p["verdict"] = verdict;
  return p;
}

// lbpkit's own discovery over the same link: in a thread moved into the
// namespace (setns), from opening the link to the first normal cycle.
json lbpkitDiscovery(const LinuxCncLink& link, unsigned mode) {
  json out;
  std::string error;
  std::thread worker([&] {
    try {
      const int fd = ::open(("/var/run/netns/" + link.ns()).c_str(), O_RDONLY | O_CLOEXEC);
      if (fd < 0 || ::setns(fd, CLONE_NEWNET) != 0) throw lbpkit::Error("cannot enter the network namespace");
      ::close(fd);
      const auto t0 = std::chrono::steady_clock::now();
      lbpkit::Lbp16Transport t(link.cardIp());
      const auto info = lbpkit::readCardInfo(t);
      lbpkit::SmartSerial::Options o;
      o.channelMask = 0x03;
      o.modes[0] = static_cast<std::uint8_t>(mode);
      lbpkit::SmartSerial ss(t, info, o);
      ss.discover(0x03);
      const auto discovered = std::chrono::steady_clock::now();
      ss.startNormal();
      const auto st = ss.cycle();
      const auto ready = std::chrono::steady_clock::now();
      out = {{"doits", ss.discoveryStats().doits},
             {"exchanges", t.exchanges()},
             {"discovery_ms", std::chrono::duration<double, std::milli>(discovered - t0).count()},
             {"ready_ms", std::chrono::duration<double, std::milli>(ready - t0).count()},
             {"first_cycle_ok", st.ok}};
    } catch (const std::exception& e) {
      error = e.what();
    }
  });
  worker.join();
  if (!error.empty()) out["error"] = error;
  return out;
}

std::uint64_t simDoits(const SimProcess& sim) {
  const auto s = sim.state();
  return s.contains("sserial") ? s["sserial"]["doits"].get<std::uint64_t>() : 0;
}

json discoveryPoint(LinuxCncLink& link, unsigned mode) {
  json p{{"mode", mode}};
  {
    SimProcess sim(link.cardIp());
    // rtapi_app and hostmot2 first: what is timed is hm2_eth's own load.
    const auto r0 = link.halcmd({"loadrt", "hostmot2"});
    if (r0.exit != 0) throw lbpkit::Error("halcmd loadrt hostmot2 failed: " + r0.out);
    const auto d0 = simDoits(sim);
    const auto t0 = std::chrono::steady_clock::now();
    const auto r = link.halcmd({"loadrt", "hm2_eth", "board_ip=" + link.cardIp(),
                                fmt::format("config=num_encoders=6 sserial_port_0={}0xxxx", mode)});
    const auto t1 = std::chrono::steady_clock::now();
    const auto d1 = simDoits(sim);
    link.unload();
    p["linuxcnc"] = {{"doits", d1 - d0}, {"wall_ms", std::chrono::duration<double, std::milli>(t1 - t0).count()}};
    if (r.exit != 0) p["linuxcnc"]["error"] = r.out;
  }
  {
    SimProcess sim(link.cardIp());
    const auto d0 = simDoits(sim);
    auto l = lbpkitDiscovery(link, mode);
    l["doits_seen_by_sim"] = simDoits(sim) - d0;
    p["lbpkit"] = l;
  }
  checkStop();
  const auto& l = p["lbpkit"];
  const auto& c = p["linuxcnc"];
  if (l.contains("ready_ms") && c["doits"].get<double>() > 0) {
    p["doit_ratio"] = l["doits_seen_by_sim"].get<double>() / c["doits"].get<double>();
    p["time_ratio"] = l["ready_ms"].get<double>() / c["wall_ms"].get<double>();
  }
  return p;
}

}  // namespace

json runNetwork(const Options& o) {
  if (auto why = unavailable()) return {{"skipped", *why}};
  LinuxCncLink link;
  json j{{"seconds_per_point", o.seconds}, {"points", json::array()}};
  for (const char* load : {"idle", "loaded"}) {
    std::optional<CpuHog> hog;
    if (std::string(load) == "loaded") {
      hog.emplace();
      j["hog_processes"] = hog->processes();
    }
    j["load_average_" + std::string(load)] = loadAverage();
    for (const unsigned rate : o.rates) j["points"].push_back(networkPoint(link, rate, o.seconds, load));
    // The sim holding the CPUs' wake-up latency, at a servo thread's usual rate.
    if (o.cpuLatencyUs >= 0)
      j["points"].push_back(networkPoint(link, 1000, o.seconds, load,
                                         {fmt::format("L{}", o.cpuLatencyUs), {"--cpu-latency", std::to_string(o.cpuLatencyUs)}}));
  }
  j["goal"] = "0 packet errors at every rate, idle and loaded; the sim's wake-to-reply p99.9 under 50 us";
  return j;
}

json runDiscovery(const Options&) {
  if (auto why = unavailable()) return {{"skipped", *why}};
  LinuxCncLink link;
  json j{{"points", json::array()}};
  for (const unsigned mode : {0U, 3U}) j["points"].push_back(discoveryPoint(link, mode));
  j["goal"] = "lbpkit: at most 1/10 of LinuxCNC's DOITs and of its time";
  return j;
}

namespace {
std::string us(const json& v) { return v.is_number() ? fmt::format("{:.0f}", v.get<double>()) : "-"; }
}  // namespace

void printNetwork(const json& j) {
  fmt::print("On the network: LinuxCNC hm2_eth (7I92 + 7I77, 6 encoders) against `lbpkit sim` over a veth pair:\n");
  if (printedSkip(j)) return;
  fmt::print("  {} s per point; loaded = {} spinning processes at normal priority\n", j["seconds_per_point"].get<double>(),
             j.value("hog_processes", 0));
  fmt::print("  {:<7} {:>6} {:>5} {:>9} {:>7} {:>8} | {:^26} | {:^26} | {:>6} {:>5} | {:>9}\n", "load", "rate",
             "sim", "datagrams", "errors", "io_error", "sim server us med/99/99.9/max",
             "sim wake-up us med/99/99.9/max", "slow", "CPU%", "LCNC late");
  for (const auto& p : j["points"]) {
    if (p.contains("error")) {
      fmt::print("  {:<7} {:>5}k {:>5}  {}\n", p["load"].get<std::string>(), p["rate_hz"].get<unsigned>() / 1000,
                 p.value("variant", std::string("-")), p["error"].get<std::string>());
      continue;
    }
    const auto& s = p["sim"]["server_us"];
    const auto& w = p["sim"]["wake_us"];
    fmt::print("  {:<7} {:>4}k {:>5} {:>9} {:>7} {:>8} | {:>5}/{:>5}/{:>5}/{:>7}  | {:>5}/{:>5}/{:>5}/{:>7}  | {:>6} {:>5.1f} | {:>6} us\n",
               p["load"].get<std::string>(), p["rate_hz"].get<unsigned>() / 1000.0,
               p.value("variant", std::string("-")), p["datagrams"].get<std::uint64_t>(), p["packet_errors"].get<std::int64_t>(),
               p["io_error"].get<bool>() ? "TRUE" : "FALSE", us(s["median"]), us(s["p99"]), us(s["p999"]),
               us(s["max"]), us(w["median"]), us(w["p99"]), us(w["p999"]), us(w["max"]),
               p["sim"]["slower_than_timeout"].get<std::uint64_t>(), p["sim"].value("cpu_percent", 0.0),
               us(p["linuxcnc"]["worst_wake_error_us"]));
  }
  fmt::print("  slow: datagrams the sim took at least hm2_eth's read timeout (80 % of the period) to answer;\n"
             "  sim: LN the sim holding the CPUs' wake-up latency at N us (lbpkit sim --cpu-latency N);\n"
             "  CPU%: the sim's CPU time over the point;\n"
             "  LCNC late: LinuxCNC's servo thread's worst wake-up error (timedelta), its own lateness.\n");
  for (const auto& p : j["points"])
    if (p.contains("verdict") && p["verdict"] != "clean")
      fmt::print("  {} {} Hz: {}\n", p["load"].get<std::string>(), p["rate_hz"].get<unsigned>(),
                 p["verdict"].get<std::string>());
  if (!j["points"].empty() && j["points"][0].contains("linuxcnc"))
    fmt::print("  LinuxCNC's servo thread ran at {}; the sim's card thread at {}.\n",
               j["points"][0]["linuxcnc"]["scheduling"].get<std::string>(),
               j["points"][0]["sim"]["scheduling"].get<std::string>());
  fmt::print("  goal: {}\n\n", j["goal"].get<std::string>());
}

void printDiscovery(const json& j) {
  fmt::print("Discovery and time to ready, same sim and veth link:\n");
  if (printedSkip(j)) return;
  fmt::print("  {:<6} {:>14} {:>14} {:>8} | {:>16} {:>16} {:>8}\n", "mode", "LinuxCNC DOITs", "lbpkit DOITs", "ratio",
             "loadrt hm2_eth ms", "lbpkit ready ms", "ratio");
  for (const auto& p : j["points"]) {
    const auto& l = p["lbpkit"];
    const auto& c = p["linuxcnc"];
    if (l.contains("error") || !p.contains("doit_ratio")) {
      fmt::print("  mode {}: {}\n", p["mode"].get<unsigned>(),
                 l.contains("error") ? l["error"].dump() : c.value("error", std::string("no DOITs counted")));
      continue;
    }
    fmt::print("  {:<6} {:>14} {:>14} {:>7.2f}x | {:>16.0f} {:>16.1f} {:>7.2f}x\n", p["mode"].get<unsigned>(),
               c["doits"].get<std::uint64_t>(), l["doits_seen_by_sim"].get<std::uint64_t>(),
               p["doit_ratio"].get<double>(), c["wall_ms"].get<double>(), l["ready_ms"].get<double>(),
               p["time_ratio"].get<double>());
  }
  fmt::print("  LinuxCNC: `halcmd loadrt hm2_eth` (rtapi_app and hostmot2 already loaded), process start to return;\n"
             "  lbpkit: open the link, discover both channels, start them, first normal cycle done (in the bench's\n"
             "  process, no exec). DOITs as the sim counted them. goal: {}\n\n",
             j["goal"].get<std::string>());
}

}  // namespace lbpkit::app::bench
