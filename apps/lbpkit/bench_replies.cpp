// SPDX-License-Identifier: MIT
// `lbpkit bench --only replies`: how fast the sim answers, beside the
// most trivial server there is. A client at 1 kHz (a servo thread's rate,
// SCHED_FIFO when allowed) sends one small datagram a cycle and times the
// round trip, first to a ten-line Python UDP echo server, then to
// `lbpkit sim` (an LBP16 read of eight words, as hm2_eth's smallest read),
// over loopback, idle and beside one spinning process per CPU. Both servers
// run at the sim's card thread's priority (SCHED_FIFO 40 as root), so what
// differs is what each does between the kernel's wake-up and its reply.
// Twice: client and server on any CPU (each datagram wakes a thread on the
// other CPU), and all on the last CPU (the server preempts the client there:
// no wake-up across CPUs, `lbpkit sim --cpu N`'s way).
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/core.h>

#include <algorithm>
#include <ctime>
#include <memory>
#include <thread>

#include "bench.hpp"
#include "common.hpp"
#include "lbpkit/error.hpp"
#include "lbpkit/wire/lbp16.hpp"
#include "process/process.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;

namespace lbpkit::app::bench {
namespace {

using nlohmann::json;
namespace lbp16 = lbpkit::wire::lbp16;

constexpr const char* kEchoAddress = "127.78.0.1";
constexpr const char* kSimAddress = "127.78.0.2";
constexpr const char* kVariantAddress = "127.78.0.3";
constexpr std::uint16_t kEchoPort = 27190;

// The comparison: a UDP echo server in ten lines of Python, as anyone
// would write one.
constexpr const char* kEchoServer =
    "import socket, sys\n"
    "s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)\n"
    "s.bind((sys.argv[1], int(sys.argv[2])))\n"
    "print('ready', flush=True)\n"
    "while True:\n"
    "    data, peer = s.recvfrom(2048)\n"
    "    s.sendto(data, peer)\n";

// Pins the calling thread (or process) to CPU `cpu`.
void pinTo(int cpu) { (void)lbpkit::process::pinToCpu(static_cast<unsigned>(cpu)); }

// python3 (from the system's folders) running kEchoServer at SCHED_FIFO 40
// when allowed (on CPU `cpu` alone unless it is -1), stopped by the
// destructor.
class EchoServer {
 public:
  explicit EchoServer(int cpu) {
    const std::string python = installed("python3");
    const std::string port = std::to_string(kEchoPort);
    int out[2];
    if (::pipe2(out, O_CLOEXEC) != 0) throw lbpkit::Error("pipe failed");
    pid_ = ::fork();
    if (pid_ < 0) throw lbpkit::Error("fork failed");
    if (pid_ == 0) {
      ::prctl(PR_SET_PDEATHSIG, SIGTERM);
      sched_param sp{};
      sp.sched_priority = 40;
      (void)::sched_setscheduler(0, SCHED_FIFO, &sp);
      if (cpu >= 0) pinTo(cpu);
      ::dup2(out[1], 1);
      ::execl(python.c_str(), "python3", "-c", kEchoServer, kEchoAddress, port.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ::close(out[1]);
    pollfd p{out[0], POLLIN, 0};
    char buf[16] = {};
    const bool ready = ::poll(&p, 1, 10'000) > 0 && ::read(out[0], buf, sizeof buf - 1) > 0;
    ::close(out[0]);
    if (!ready) {
      stop();
      throw lbpkit::Error("the Python echo server did not start (is python3 installed?)");
    }
  }
  ~EchoServer() { stop(); }
  EchoServer(const EchoServer&) = delete;
  EchoServer& operator=(const EchoServer&) = delete;
  [[nodiscard]] pid_t pid() const { return pid_; }

 private:
  void stop() {
    stopProcess(pid_);
    pid_ = -1;
  }
  pid_t pid_ = -1;
};

struct Trips {
  std::vector<std::int64_t> ns;  // each reply's round trip
  std::uint64_t sent = 0, late = 0, lost = 0;
  std::string scheduling = "SCHED_OTHER";
};

// One datagram a millisecond for `seconds` to ADDRESS:PORT, each reply
// awaited 800 us (hm2_eth's read timeout at 1 kHz): its round trip, or late
// (came after that), or lost.
Trips roundTrips(const std::string& address, std::uint16_t port, std::span<const std::uint8_t> request,
                 double seconds, int cpu) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(port);
  ::inet_pton(AF_INET, address.c_str(), &sa.sin_addr);
  if (fd < 0 || ::connect(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0) {
    if (fd >= 0) ::close(fd);
    throw lbpkit::Error("cannot open a UDP socket to " + address);
  }
  Trips t;
  const auto cycles = static_cast<std::uint64_t>(seconds * 1000.0);
  t.ns.reserve(cycles);
  std::thread worker([&] {
    sched_param sp{};
    sp.sched_priority = 30;
    if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp) == 0) t.scheduling = "SCHED_FIFO priority 30";
    if (cpu >= 0) pinTo(cpu);
    auto nowNs = [] {
      timespec n{};
      ::clock_gettime(CLOCK_MONOTONIC, &n);
      return n.tv_sec * 1'000'000'000L + n.tv_nsec;
    };
    constexpr long kPeriodNs = 1'000'000, kTimeoutNs = 800'000;
    std::uint8_t reply[512];
    long next = nowNs();
    for (std::uint64_t c = 0; c < cycles && !app::gStop.load(); ++c) {
      next += kPeriodNs;
      const timespec at{static_cast<time_t>(next / 1'000'000'000L), next % 1'000'000'000L};
      while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &at, nullptr) == EINTR) {
      }
      while (::recv(fd, reply, sizeof reply, MSG_DONTWAIT) > 0) ++t.late;
      const long start = nowNs();
      if (::send(fd, request.data(), request.size(), 0) != static_cast<ssize_t>(request.size())) continue;
      ++t.sent;
      bool answered = false;
      for (long left = kTimeoutNs; left > 0; left = start + kTimeoutNs - nowNs()) {
        pollfd p{fd, POLLIN, 0};
        const timespec ts{0, left};
        if (::ppoll(&p, 1, &ts, nullptr) > 0 && ::recv(fd, reply, sizeof reply, MSG_DONTWAIT) > 0) {
          t.ns.push_back(nowNs() - start);
          answered = true;
          break;
        }
      }
      if (!answered) ++t.lost;  // provisionally: a late one takes it back
      if (nowNs() - next > kPeriodNs) next = nowNs();  // overran: start again from now
    }
    ::usleep(20'000);
    while (::recv(fd, reply, sizeof reply, MSG_DONTWAIT) > 0) ++t.late;
  });
  worker.join();
  ::close(fd);
  t.lost = t.lost >= t.late ? t.lost - t.late : 0;
  checkStop();
  std::sort(t.ns.begin(), t.ns.end());
  return t;
}

double percentileUs(const std::vector<std::int64_t>& sorted, double p) {
  if (sorted.empty()) return 0;
  const auto i = std::min(sorted.size() - 1, static_cast<std::size_t>(p * static_cast<double>(sorted.size())));
  return static_cast<double>(sorted[i]) / 1000.0;
}

// The round trips to one server, and the CPU time its process took meanwhile.
Trips measured(pid_t server, const std::string& address, std::uint16_t port, std::span<const std::uint8_t> request,
               double seconds, int cpu, double& cpuPercent) {
  const CpuMeter meter({server});
  Trips t = roundTrips(address, port, request, seconds, cpu);
  cpuPercent = meter.percent();
  return t;
}

json point(const char* cpus, const char* load, const std::string& server, const Trips& t, double cpuPercent) {
  return {{"cpus", cpus},
          {"load", load},
          {"server", server},
          {"server_cpu_percent", cpuPercent},
          {"client", t.scheduling},
          {"sent", t.sent},
          {"late", t.late},
          {"lost", t.lost},
          {"us", {{"median", percentileUs(t.ns, 0.5)},
                  {"p99", percentileUs(t.ns, 0.99)},
                  {"p999", percentileUs(t.ns, 0.999)},
                  {"max", t.ns.empty() ? 0.0 : static_cast<double>(t.ns.back()) / 1000.0}}}};
}

}  // namespace

json runReplies(const Options& o) {
  json j{{"points", json::array()},
         {"goal", "the sim's round trip p99.9 under 50 us at 1 kHz, idle and loaded, beside the echo server's"}};
  if (!lbpkit::process::systemProgram("python3"))
    return {{"skipped", "python3 is not installed (the echo server it is compared with)"}};
  const std::uint16_t cmd = lbp16::hm2Read(8);
  const std::uint8_t read[4] = {static_cast<std::uint8_t>(cmd), static_cast<std::uint8_t>(cmd >> 8), 0x00, 0x01};
  // The last CPU this process may run on (a cpuset or taskset may leave
  // it fewer than the machine has).
  const auto allowed = lbpkit::process::allowedCpus();
  const int last = allowed.empty() ? 0 : static_cast<int>(allowed.back());
  for (const int cpu : {-1, last}) {
    EchoServer echo(cpu);
    std::vector<std::string> simArgs;
    if (cpu >= 0) simArgs = {"--cpu", std::to_string(cpu)};
    SimProcess sim(kSimAddress, simArgs);
    sleepFor(std::chrono::milliseconds(500));
    const char* cpus = cpu < 0 ? "any" : "one";
    for (const bool loaded : {false, true}) {
      std::unique_ptr<CpuHog> hog;
      if (loaded) hog = std::make_unique<CpuHog>();
      const char* load = loaded ? "loaded" : "idle";
      double busy = 0;
      Trips t = measured(echo.pid(), kEchoAddress, kEchoPort, read, o.seconds, cpu, busy);
      j["points"].push_back(point(cpus, load, "echo", t, busy));
      t = measured(sim.pid(), kSimAddress, lbp16::kPort, read, o.seconds, cpu, busy);
      j["points"].push_back(point(cpus, load, "sim", t, busy));
      if (o.cpuLatencyUs >= 0) {
        // The same sim holding the CPUs' wake-up latency (--cpu-latency), on
        // an address of its own and running for this point only: the
        // latency request is the whole machine's.
        std::vector<std::string> args = simArgs;
        args.insert(args.end(), {"--cpu-latency", std::to_string(o.cpuLatencyUs)});
        SimProcess variant(kVariantAddress, args);
        sleepFor(std::chrono::milliseconds(300));
        t = measured(variant.pid(), kVariantAddress, lbp16::kPort, read, o.seconds, cpu, busy);
        auto pt = point(cpus, load, fmt::format("sim L{}", o.cpuLatencyUs), t, busy);
        pt["sim_server"] = variant.state()["server"];
        j["points"].push_back(pt);
      }
    }
    j["sim_scheduling"] = sim.state()["server"]["scheduling"];
  }
  return j;
}

void printReplies(const json& j) {
  fmt::print("Replies: a client's round trip at 1 kHz over loopback, to a ten-line Python UDP echo server and to\n"
             "`lbpkit sim` (an LBP16 read of 8 words), each reply awaited 800 us:\n");
  if (printedSkip(j)) return;
  fmt::print("  {:<5} {:<7} {:<7} {:>8} | {:>32} | {:>6} {:>6} | {:>7}\n", "CPUs", "load", "to", "sent",
             "round trip us med/99/99.9/max", "late", "lost", "server%");
  for (const auto& p : j["points"]) {
    const auto& us = p["us"];
    fmt::print("  {:<5} {:<7} {:<7} {:>8} | {:>8.1f}/{:>7.1f}/{:>7.1f}/{:>7.1f} | {:>6} {:>6} | {:>7.2f}\n",
               p.value("cpus", std::string("any")), p["load"].get<std::string>(), p["server"].get<std::string>(),
               p["sent"].get<std::uint64_t>(),
               us["median"].get<double>(), us["p99"].get<double>(), us["p999"].get<double>(),
               us["max"].get<double>(), p["late"].get<std::uint64_t>(), p["lost"].get<std::uint64_t>(),
               p.value("server_cpu_percent", 0.0));
  }
  if (!j["points"].empty())
    fmt::print("  client: {}; both servers at the sim's card thread's scheduling ({}).\n"
               "  CPUs: any (client and server where the kernel puts them), one (all on the last CPU, the server\n"
               "  preempting the client); loaded: one spinning process per CPU at normal priority.\n"
               "  sim LN: the sim holding the CPUs' wake-up latency at N us (lbpkit sim --cpu-latency N);\n"
               "  server%: the server process's CPU time over the point, in % of one CPU (the idle CPUs'\n"
               "  polling under --cpu-latency is not in it).\n",
               j["points"][0]["client"].get<std::string>(), j.value("sim_scheduling", std::string("?")));
  fmt::print("  goal: {}\n\n", j["goal"].get<std::string>());
}

}  // namespace lbpkit::app::bench
