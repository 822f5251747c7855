// The virtual mill (issue 10): how many simulated seconds the in-process
// card plus the machine behind it run per second of CPU, with the host
// cycle at 1 kHz closing a P position loop on every axis (as a LinuxCNC
// servo thread would), the spindle running. The counter sim_s_per_s is the
// figure; BM_MillPlantOnly is the machine alone (no host, card not cycled),
// to show where the time goes.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <string>

#include "lbpkit/encoders.hpp"
#include "lbpkit/sserial.hpp"
#include "machine/machine.hpp"
#include "running_card.hpp"

namespace {

using namespace std::chrono_literals;

void BM_MillClosedLoop(benchmark::State& state) {
  auto d = machine::mill();
  d.step = std::chrono::microseconds(state.range(0));
  testing_host::RunningCard rc;  // both 7I77 channels discovered and started
  auto& t = rc.t;
  auto& ss = rc.ss;
  lbpkit::MuxedEncoders enc(t, rc.info);
  enc.initialize();
  machine::Machine m(d, t.card(), hm2::SimTime{t.now()});
  std::array<lbpkit::ElementRef, 6> aout;
  for (unsigned i = 0; i < 6; ++i) aout[i] = ss.find(1, "analogout" + std::to_string(i));
  ss.setRaw(ss.find(1, "analogena"), 1);
  ss.setRaw(ss.find(1, "spinena"), 1);
  ss.setRaw(ss.find(0, "output"), 0x7);  // coolant, lube, Z brake released
  ss.set(aout[5], 5.0);
  for (unsigned a = 0; a < 3; ++a) enc.setScale(a, 1600.0);
  const std::array<double, 3> initial{200.0, 150.0, -75.0};
  std::array<double, 3> offset{};
  std::uint64_t cycles = 0;
  const auto begin = t.now();
  for (auto _ : state) {
    const auto start = t.now();
    // Targets move back and forth over 40 mm every 2 s, so the axes work.
    const double phase = static_cast<double>(cycles % 2000) / 2000.0;
    for (unsigned a = 0; a < 3; ++a) {
      const double target = initial[a] + (phase < 0.5 ? 20.0 : -20.0);
      const double pos = initial[a] + enc.position(a) - offset[a];
      ss.set(aout[a], std::clamp(5.0 * (target - pos), -10.0, 10.0));
    }
    ss.queueOutputs();
    enc.queue();
    t.flush();
    const auto st = ss.collectInputs();
    enc.update();
    if (cycles == 0)
      for (unsigned a = 0; a < 3; ++a) offset[a] = enc.position(a);
    m.advance(hm2::SimTime{start + 1ms});
    t.sleep(start + 1ms - t.now());
    benchmark::DoNotOptimize(st);
    ++cycles;
  }
  const double simulated = std::chrono::duration<double>(t.now() - begin).count();
  state.counters["sim_s_per_s"] = benchmark::Counter(simulated, benchmark::Counter::kIsRate);
  state.counters["x_mm"] = m.axis(0).position();
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
