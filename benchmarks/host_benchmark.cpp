// SPDX-License-Identifier: MIT
// Figures docs/library.md quotes: the cost of one full host cycle for one 7I77
// through the in-process card, and how many DOITs a full discovery takes.
#include <benchmark/benchmark.h>

#include "support/running_card.hpp"
#include "sim_card/sim_transport.hpp"
#include "lbpkit/sserial.hpp"

namespace {

using namespace std::chrono_literals;

// pack outputs, DOIT, wait, unpack inputs, scale: everything a servo thread
// does for the 7I77 per period. The time includes the simulated card and
// remotes answering in process (no wire, no kernel).
void BM_FullCycle(benchmark::State& state) {
  testing_host::RunningCard rc;  // both 7I77 channels discovered and started
  auto& t = rc.t;
  auto& ss = rc.ss;
  const auto output = ss.find(0, "output");
  const auto input = ss.find(0, "input");
  std::array<lbpkit::ElementRef, 6> aout;
  for (unsigned i = 0; i < 6; ++i) aout[i] = ss.find(1, "analogout" + std::to_string(i));
  std::uint64_t n = 0;
  double sink = 0;
  for (auto _ : state) {
    ss.setRaw(output, n & 0xFFFF);
    for (unsigned i = 0; i < 6; ++i) ss.set(aout[i], static_cast<double>(n % 20) - 10.0);
    const auto st = ss.cycle();
    sink += ss.value(input) + (st.ok ? 0 : 1);
    benchmark::DoNotOptimize(sink);
    t.sleep(1ms);  // simulated: costs no real time
    ++n;
  }
  state.counters["exchanges/cycle"] = static_cast<double>(t.exchanges()) / static_cast<double>(n);
}
BENCHMARK(BM_FullCycle);

void BM_Discovery(benchmark::State& state) {
  std::uint64_t doits = 0, bytewise = 0, runs = 0;
  double simulatedMs = 0;
  for (auto _ : state) {
    lbpkit::SimTransport t;
    const auto info = lbpkit::readCardInfo(t);
    lbpkit::SmartSerial::Options o;
    o.channelMask = 0x03;
    o.modes[0] = static_cast<std::uint8_t>(state.range(0));
    lbpkit::SmartSerial ss(t, info, o);
    ss.discover(0x03);
    doits += ss.discoveryStats().doits;
    simulatedMs += std::chrono::duration<double, std::milli>(ss.discoveryStats().time).count();
    // What one-DOIT-per-byte reading (LinuxCNC's driver) would take.
    for (unsigned s = 0; s < ss.slots(); ++s) bytewise += ss.description(s).bytewiseReads();
    ++runs;
  }
  state.counters["doits"] = static_cast<double>(doits) / static_cast<double>(runs);
  state.counters["bytewise_doits"] = static_cast<double>(bytewise) / static_cast<double>(runs);
  state.counters["simulated_ms"] = simulatedMs / static_cast<double>(runs);
}
BENCHMARK(BM_Discovery)->Arg(0)->Arg(3)->Unit(benchmark::kMillisecond);

}  // namespace


