// SPDX-License-Identifier: MIT
// `lbpkit bench --only inprocess`: the host library over the in-process card
// (lbpkit::SimTransport), host cycle at 1 kHz, for N simulated seconds: the
// board alone, and the board with the mill machine behind it (a P position
// loop on every axis, all six encoders turning, the spindle running), side by side.
// The board alone is BM_FullCycle's loop; the mill is lbpkit::MillClosedLoop,
// as BM_MillClosedLoop runs it; timed on this thread's CPU clock.
#include <fmt/core.h>

#include <algorithm>
#include <array>
#include <ctime>
#include <string>

#include "bench.hpp"
#include "lbpkit/sserial.hpp"
#include "sim_card/mill_closed_loop.hpp"
#include "sim_card/sim_transport.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;

namespace lbpkit::app::bench {
namespace {

using namespace std::chrono_literals;

volatile double gSink = 0;

double threadCpuSeconds() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

// Both 7I77 channels discovered and started in normal mode.
struct Board {
  lbpkit::SimTransport t;
  lbpkit::CardInfo info;
  lbpkit::SmartSerial ss;
  static lbpkit::SmartSerial::Options channels() {
    lbpkit::SmartSerial::Options o;
    o.channelMask = 0x03;
    return o;
  }
  Board() : info(lbpkit::readCardInfo(t)), ss(t, info, channels()) {
    ss.discover(0x03);
    ss.startNormal();
  }
};

// Runs `cycle` once per simulated millisecond for `seconds` of simulated
// time; what it cost.
template <typename Cycle>
nlohmann::json timed(const char* name, const char* what, double seconds, lbpkit::SimTransport& t, Cycle&& cycle) {
  const auto cycles = static_cast<std::uint64_t>(seconds * 1000.0);
  const auto begin = t.now();
  const double cpu0 = threadCpuSeconds();
  const auto wall0 = std::chrono::steady_clock::now();
  for (std::uint64_t n = 0; n < cycles; ++n) {
    if ((n & 1023U) == 0) checkStop();
    const auto start = t.now();
    cycle(n);
    t.sleep(start + 1ms - t.now());  // simulated: costs no real time
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  const double cpu = threadCpuSeconds() - cpu0;
  const double simulated = std::chrono::duration<double>(t.now() - begin).count();
  return {{"name", name},
          {"what", what},
          {"simulated_s", simulated},
          {"wall_s", wall},
          {"cpu_s", cpu},
          {"x_real_time", simulated / std::max(wall, 1e-9)},
          // On one core of its own: what the wall figure would be on an idle machine.
          {"x_real_time_per_cpu", simulated / std::max(cpu, 1e-9)},
          {"cpu_us_per_sim_ms", cpu * 1e6 / std::max(simulated * 1000.0, 1e-9)}};
}

nlohmann::json boardAlone(double seconds) {
  Board b;
  auto& ss = b.ss;
  const auto output = ss.find(0, "output");
  const auto input = ss.find(0, "input");
  std::array<lbpkit::ElementRef, 6> aout;
  for (unsigned i = 0; i < 6; ++i) aout[i] = ss.find(1, "analogout" + std::to_string(i));
  double sink = 0;
  auto j = timed("board alone", "7I92 + 7I77, both channels' process data per cycle", seconds, b.t,
                 [&](std::uint64_t n) {
                   ss.setRaw(output, n & 0xFFFF);
                   for (unsigned i = 0; i < 6; ++i) ss.set(aout[i], static_cast<double>(n % 20) - 10.0);
                   const auto st = ss.cycle();
                   sink += ss.value(input) + (st.ok ? 0 : 1);
                 });
  gSink = sink;  // keeps the loop's work observable
  return j;
}

nlohmann::json boardWithMill(double seconds) {
  lbpkit::MillClosedLoop mill;
  return timed("board + mill", "the same, the mill behind it: 5 axes in a P loop, all 6 encoders turning, spindle", seconds,
               mill.transport(), [&](std::uint64_t) { (void)mill.cycle(); });
}

}  // namespace

nlohmann::json runInProcess(const Options& o) {
  nlohmann::json j;
  j["simulated_s"] = o.seconds;
  j["host_cycle_hz"] = 1000;
  j["goal"] = {{"x_real_time", 2000}, {"cpu_us_per_sim_ms", 0.5}};
  j["rows"] = nlohmann::json::array({boardAlone(o.seconds), boardWithMill(o.seconds)});
  j["load_average"] = loadAverage();
  return j;
}

void printInProcess(const nlohmann::json& j) {
  fmt::print("In process (host library over lbpkit::SimTransport, host cycle 1 kHz, {} simulated s each, one thread):\n",
             j["simulated_s"].get<double>());
  fmt::print("  {:<14} {:>18} {:>18} {:>16}   {}\n", "", "x real time (wall)", "x real time (CPU)", "CPU us / sim ms",
             "what");
  for (const auto& r : j["rows"])
    fmt::print("  {:<14} {:>18.0f} {:>18.0f} {:>16.2f}   {}\n", r["name"].get<std::string>(),
               r["x_real_time"].get<double>(), r["x_real_time_per_cpu"].get<double>(),
               r["cpu_us_per_sim_ms"].get<double>(), r["what"].get<std::string>());
  fmt::print("  wall: simulated / elapsed time (other work on the machine takes its share); CPU: simulated / this\n"
             "  thread's CPU time (the figure on a core of its own).\n");
  fmt::print("  goal: >= {} x real time, <= {} us of CPU per simulated ms (board + mill)\n\n",
             j["goal"]["x_real_time"].get<int>(), j["goal"]["cpu_us_per_sim_ms"].get<double>());
}

}  // namespace lbpkit::app::bench
