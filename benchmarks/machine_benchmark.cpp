// SPDX-License-Identifier: MIT
// The virtual mill: how many simulated seconds the in-process card plus
// the machine behind it run per second of CPU, in the one in-process
// scenario (lbpkit::MillClosedLoop: a P position loop on every axis at
// 1 kHz, all six of the 7I77's encoders turning). Counters x_real_time
// (simulated seconds per CPU second) and cpu_us_per_sim_ms; the goal is
// 2000 x (0.5 us). BM_MillPlantOnly is the machine alone (no host, card
// not cycled), to show where the time goes.
#include <benchmark/benchmark.h>

#include <chrono>
#include <utility>

#include "machine/machine.hpp"
#include "sim_card/mill_closed_loop.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace machine = lbpkit::model::machine;

namespace {

using namespace std::chrono_literals;

void simulatedRate(benchmark::State& state, double simulatedSeconds) {
  state.counters["x_real_time"] = benchmark::Counter(simulatedSeconds, benchmark::Counter::kIsRate);
  state.counters["cpu_us_per_sim_ms"] =
      benchmark::Counter(simulatedSeconds, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_MillClosedLoop(benchmark::State& state) {
  lbpkit::MillClosedLoop mill(std::chrono::microseconds(state.range(0)));
  const double begin = mill.simulatedSeconds();
  for (auto _ : state) benchmark::DoNotOptimize(mill.cycle());
  if (!mill.status().ok) state.SkipWithError("a cycle failed");
  simulatedRate(state, mill.simulatedSeconds() - begin);
}
// The plant's longest span in microseconds: 1000 (the default), 50 (the
// plant looking at the 7I77's outputs and aiming its encoders 20 times a period).
BENCHMARK(BM_MillClosedLoop)->Arg(1000)->Arg(50)->Unit(benchmark::kMicrosecond);

void BM_MillPlantOnly(benchmark::State& state) {
  hm2::HostMot2Card card;
  machine::Machine m(machine::mill(), card);
  hm2::SimTime now{0};
  for (auto _ : state) {
    now += 1ms;
    m.advance(now);
    benchmark::DoNotOptimize(m.time());
  }
  simulatedRate(state, std::chrono::duration<double>(now).count());
}
BENCHMARK(BM_MillPlantOnly)->Unit(benchmark::kMicrosecond);

}  // namespace
