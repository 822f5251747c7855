// SPDX-License-Identifier: MIT
// `lbpkit bench --only boards`: N boards on N loopback addresses (a CI
// farm's), as N `lbpkit sim` processes and as one process serving N cards,
// side by side: their memory and CPU per board at idle and while a client
// drives all of them at 1 kHz, and what that client saw: each cycle one
// hm2_eth-shaped read to every board at once, replies awaited for 80 % of
// the period (hm2_eth's read timeout); late and lost replies counted.
// N = 1 is the comparison: what one board costs alone.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/core.h>

#include <ctime>
#include <memory>
#include <thread>

#include "bench.hpp"
#include "common.hpp"
#include "lbpkit/error.hpp"
#include "lbpkit/wire/lbp16.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;

namespace lbpkit::app::bench {
namespace {

using nlohmann::json;
namespace lbp16 = lbpkit::wire::lbp16;

std::string boardAddress(unsigned i) { return fmt::format("127.79.{}.{}", i / 250, i % 250 + 1); }

struct Driven {
  std::uint64_t sent = 0, onTime = 0, late = 0, lost = 0, clientLateCycles = 0;
  std::string scheduling = "SCHED_OTHER";
};

// Drives every board at 1 kHz for `seconds`, on a thread of its own (at
// SCHED_FIFO below the sims' card threads when allowed, as a servo thread).
Driven drive(const std::vector<std::unique_ptr<SimProcess>>& sims, double seconds) {
  Driven d;
  std::vector<int> fds;
  for (const auto& s : sims)
    for (const auto& address : s->addresses()) {
      const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
      sockaddr_in sa{};
      sa.sin_family = AF_INET;
      sa.sin_port = htons(lbp16::kPort);
      ::inet_pton(AF_INET, address.c_str(), &sa.sin_addr);
      if (fd < 0 || ::connect(fd, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0) {
        for (const int f : fds) ::close(f);
        if (fd >= 0) ::close(fd);
        throw lbpkit::Error("cannot open a UDP socket to " + address);
      }
      fds.push_back(fd);
    }
  std::thread worker([&] {
    sched_param sp{};
    sp.sched_priority = 30;
    if (pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp) == 0) d.scheduling = "SCHED_FIFO priority 30";
    // A read of 8 words from the IDROM's start (8 + 32 bytes, as a small
    // hm2_eth read of the card's registers).
    const std::uint16_t cmd = lbp16::hm2Read(8);
    const std::uint8_t request[4] = {static_cast<std::uint8_t>(cmd), static_cast<std::uint8_t>(cmd >> 8), 0x00, 0x01};
    std::vector<pollfd> p(fds.size());
    std::vector<bool> waiting(fds.size(), false);
    std::uint8_t reply[256];
    constexpr long kPeriodNs = 1'000'000, kTimeoutNs = 800'000;
    timespec next{};
    ::clock_gettime(CLOCK_MONOTONIC, &next);
    const auto cycles = static_cast<std::uint64_t>(seconds * 1000.0);
    auto nowNs = [] {
      timespec t{};
      ::clock_gettime(CLOCK_MONOTONIC, &t);
      return t.tv_sec * 1'000'000'000L + t.tv_nsec;
    };
    for (std::uint64_t c = 0; c < cycles && !app::gStop.load(); ++c) {
      next.tv_nsec += kPeriodNs;
      if (next.tv_nsec >= 1'000'000'000L) {
        next.tv_nsec -= 1'000'000'000L;
        ++next.tv_sec;
      }
      while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, nullptr) == EINTR) {
      }
      const long start = nowNs();
      const long behind = start - (next.tv_sec * 1'000'000'000L + next.tv_nsec);
      if (behind > kPeriodNs / 2) ++d.clientLateCycles;
      // A whole period behind: start again from now, as a servo thread that
      // overran does (rather than sending the missed cycles back to back).
      if (behind > kPeriodNs) {
        next.tv_sec = start / 1'000'000'000L;
        next.tv_nsec = start % 1'000'000'000L;
      }
      // What came after last cycle's timeout: late.
      for (std::size_t i = 0; i < fds.size(); ++i) {
        while (::recv(fds[i], reply, sizeof reply, MSG_DONTWAIT) > 0) ++d.late;
        if (waiting[i]) ++d.lost;  // provisionally; a late one takes it back
        waiting[i] = false;
      }
      for (std::size_t i = 0; i < fds.size(); ++i)
        if (::send(fds[i], request, sizeof request, 0) == sizeof request) {
          ++d.sent;
          waiting[i] = true;
        }
      std::size_t pending = fds.size();
      while (pending > 0) {
        const long left = start + kTimeoutNs - nowNs();
        if (left <= 0) break;
        for (std::size_t i = 0; i < fds.size(); ++i) p[i] = {waiting[i] ? fds[i] : -1, POLLIN, 0};
        const timespec ts{0, left};
        if (::ppoll(p.data(), p.size(), &ts, nullptr) <= 0) continue;
        for (std::size_t i = 0; i < fds.size(); ++i)
          if (waiting[i] && (p[i].revents & POLLIN) && ::recv(fds[i], reply, sizeof reply, MSG_DONTWAIT) > 0) {
            ++d.onTime;
            waiting[i] = false;
            --pending;
          }
      }
    }
    // The last cycle's stragglers.
    ::usleep(20'000);
    for (std::size_t i = 0; i < fds.size(); ++i) {
      while (::recv(fds[i], reply, sizeof reply, MSG_DONTWAIT) > 0) ++d.late;
      if (waiting[i]) ++d.lost;
    }
  });
  worker.join();
  for (const int f : fds) ::close(f);
  // Each late reply was first counted lost at its cycle's end.
  d.lost = d.lost >= d.late ? d.lost - d.late : 0;
  checkStop();
  return d;
}

// CPU of every sim while `during` runs (`wall`: how long that took), per board.
template <typename During>
double cpuPerBoard(const std::vector<std::unique_ptr<SimProcess>>& sims, unsigned boards, During&& during,
                   double& wall) {
  std::vector<pid_t> pids;
  for (const auto& s : sims) pids.push_back(s->pid());
  const CpuMeter cpu(std::move(pids));
  during();
  wall = cpu.wall();
  return cpu.seconds() / static_cast<double>(boards);
}

// N boards: N processes, or one process of N cards (`oneProcess`).
json boardsPoint(unsigned n, bool oneProcess, double seconds) {
  std::vector<std::unique_ptr<SimProcess>> sims;
  if (oneProcess) {
    std::vector<std::string> addresses;
    for (unsigned i = 0; i < n; ++i) addresses.push_back(boardAddress(i));
    sims.push_back(std::make_unique<SimProcess>(addresses, std::vector<std::string>{}));
  } else {
    for (unsigned i = 0; i < n; ++i) sims.push_back(std::make_unique<SimProcess>(boardAddress(i)));
  }
  sleepFor(std::chrono::seconds(1));  // past their start
  json p{{"boards", n}, {"processes", sims.size()}, {"seconds", seconds}};
  double wall = 0;
  const double idle = cpuPerBoard(sims, n, [&] { sleepFor(std::chrono::duration<double>(seconds)); }, wall);
  long rss = 0, pss = 0;
  for (const auto& s : sims) {
    const auto m = memory(s->pid());
    rss += m.rssKb;
    pss += m.pssKb;
  }
  p["memory_kb_per_board"] = {{"rss", rss / static_cast<long>(n)}, {"pss", pss / static_cast<long>(n)}};
  p["idle_cpu_percent_per_board"] = 100.0 * idle / wall;
  Driven d;
  const double busy = cpuPerBoard(sims, n, [&] { d = drive(sims, seconds); }, wall);
  p["driven_cpu_percent_per_board"] = 100.0 * busy / wall;
  p["client"] = {{"scheduling", d.scheduling},
                 {"requests", d.sent},
                 {"on_time", d.onTime},
                 {"late", d.late},
                 {"lost", d.lost},
                 {"client_late_cycles", d.clientLateCycles}};
  p["load_average"] = loadAverage();
  if (!sims.empty()) p["sim_scheduling"] = sims.front()->state()["server"]["scheduling"];
  return p;
}

}  // namespace

json runBoards(const Options& o) {
  json j{{"points", json::array()}, {"goal", "50 boards at 1 kHz on this machine with no lost or late replies"}};
  for (const unsigned n : o.boards) {
    j["points"].push_back(boardsPoint(n, false, o.seconds));
    if (n > 1) j["points"].push_back(boardsPoint(n, true, o.seconds));
  }
  return j;
}

void printBoards(const json& j) {
  fmt::print("Many boards: N boards on loopback addresses as N `lbpkit sim` processes and as one process of N cards\n"
             "(`lbpkit sim --bind A --bind B ...`), a lbpkit client reading every board at 1 kHz (reply timeout 800 us,\n"
             "as hm2_eth's):\n");
  fmt::print("  {:>6} {:>5} {:>10} {:>10} {:>10} {:>12} | {:>10} {:>8} {:>8} {:>10}\n", "boards", "procs", "RSS kB/bd",
             "PSS kB/bd", "idle CPU%", "1 kHz CPU%", "requests", "late", "lost", "own late");
  for (const auto& p : j["points"])
    fmt::print("  {:>6} {:>5} {:>10} {:>10} {:>10.2f} {:>12.2f} | {:>10} {:>8} {:>8} {:>10}\n",
               p["boards"].get<unsigned>(), p.value("processes", 0U),
               p["memory_kb_per_board"]["rss"].get<long>(), p["memory_kb_per_board"]["pss"].get<long>(),
               p["idle_cpu_percent_per_board"].get<double>(), p["driven_cpu_percent_per_board"].get<double>(),
               p["client"]["requests"].get<std::uint64_t>(), p["client"]["late"].get<std::uint64_t>(),
               p["client"]["lost"].get<std::uint64_t>(), p["client"]["client_late_cycles"].get<std::uint64_t>());
  if (!j["points"].empty())
    fmt::print("  CPU% per board is of one CPU; own late: client cycles that started over 0.5 ms late (the client's\n"
               "  own lateness, {}); sims' card threads: {}.\n",
               j["points"][0]["client"]["scheduling"].get<std::string>(),
               j["points"][0].value("sim_scheduling", std::string("?")));
  fmt::print("  goal: {}\n\n", j["goal"].get<std::string>());
}

}  // namespace lbpkit::app::bench
