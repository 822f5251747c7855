// The virtual mill: how many simulated seconds the in-process
// card plus the machine behind it run per second of CPU, with the host
// cycle at 1 kHz closing a P position loop on every axis (as a LinuxCNC
// servo thread would), the spindle running. The counter sim_s_per_s is the
// figure; BM_MillPlantOnly is the machine alone (no host, card not cycled),
// to show where the time goes.
#include <benchmark/benchmark.h>

#include <chrono>
#include <utility>

#include "machine/machine.hpp"
#include "sim_card/mill_closed_loop.hpp"

namespace {

using namespace std::chrono_literals;

void BM_MillClosedLoop(benchmark::State& state) {
  auto d = machine::mill();
  d.step = std::chrono::microseconds(state.range(0));
  lbpkit::MillClosedLoop mill(std::move(d));
  auto& t = mill.transport();
  const auto begin = t.now();
  for (auto _ : state) {
    const auto start = t.now();
    const auto st = mill.cycle();
    t.sleep(start + 1ms - t.now());
    benchmark::DoNotOptimize(st);
  }
  const double simulated = std::chrono::duration<double>(t.now() - begin).count();
  state.counters["sim_s_per_s"] = benchmark::Counter(simulated, benchmark::Counter::kIsRate);
  state.counters["x_mm"] = mill.machine().axis(0).position();
}
// The plant's step in microseconds: 50 (the default), 100.
BENCHMARK(BM_MillClosedLoop)->Arg(50)->Arg(100)->Unit(benchmark::kMicrosecond);

void BM_MillPlantOnly(benchmark::State& state) {
  hm2::HostMot2Card card;
  machine::Machine m(machine::mill(), card);
  hm2::SimTime now{0};
  for (auto _ : state) {
    now += 1ms;
    m.advance(now);
    benchmark::DoNotOptimize(m.time());
  }
  state.counters["sim_s_per_s"] =
      benchmark::Counter(std::chrono::duration<double>(now).count(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_MillPlantOnly)->Unit(benchmark::kMicrosecond);

}  // namespace
