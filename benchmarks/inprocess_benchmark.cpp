// SPDX-License-Identifier: MIT
// The in-process mill's hot paths, so a regression in one shows; the
// scenario as a whole is BM_MillClosedLoop (machine_benchmark.cpp). The
// goal is 2000 x real time on one core (0.5 us of CPU per simulated
// millisecond).
#include <benchmark/benchmark.h>

#include <array>
#include <chrono>
#include <cmath>
#include <vector>

#include "hostmot2/muxed_encoder.hpp"
#include "machine/axis.hpp"
#include "machine/machine.hpp"
#include "machine/quadrature_encoder.hpp"
#include "machine/servo_amplifier.hpp"
#include "machine/servo_motion.hpp"
#include "support/fixed_step_plant.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace machine = lbpkit::model::machine;

namespace {

using namespace std::chrono_literals;
using hm2::SimTime;

constexpr std::uint32_t kClockLow = 100'000'000;  // a 7I92's ClockLow
constexpr SimTime kPlantStep = 1ms;               // the machines' default span


// The host's cycle through the card alone is BM_FullCycle (host_benchmark.cpp);
// the plant's parts are the three below. (Timing the scenario's halves
// apart with PauseTiming would measure mostly the timer: it reads the
// process CPU clock, a system call, twice an iteration.)

// One plant step's work for six encoders (QuadratureEncoder::drive: the
// counter settled, a new velocity set), shafts turning at changing speeds;
// per iteration one span of all six: the plant does this once a period.
void BM_EncoderDrive(benchmark::State& state) {
  hm2::MuxedEncoder counters(6, kClockLow);
  std::array<machine::QuadratureEncoder, 6> encoders{
      machine::QuadratureEncoder({2000, true, false}, counters, 0, 0.0),
      machine::QuadratureEncoder({2000, true, false}, counters, 1, 0.0),
      machine::QuadratureEncoder({2000, true, false}, counters, 2, 0.0),
      machine::QuadratureEncoder({2000, true, false}, counters, 3, 0.0),
      machine::QuadratureEncoder({2000, true, false}, counters, 4, 0.0),
      machine::QuadratureEncoder({256, true, false}, counters, 5, 0.0)};
  const double seconds = std::chrono::duration<double>(kPlantStep).count();
  std::array<double, 6> revs{};
  SimTime t{0};
  std::uint64_t steps = 0;
  for (auto _ : state) {
    for (unsigned i = 0; i < 6; ++i) {
      // 1 to 4 rev/s (spindle 200), the speed changing every step.
      const double speed = (i == 5 ? 200.0 : 1.0 + i * 0.6) * (1.0 + 0.1 * static_cast<double>(steps % 7));
      revs[i] += speed * seconds;
      encoders[i].drive(revs[i], t, t + kPlantStep, seconds, machine::Machine::kEncoderMinimumSpan);
    }
    t += kPlantStep;
    ++steps;
  }
  benchmark::DoNotOptimize(counters.count(0));
  state.SetItemsProcessed(static_cast<std::int64_t>(steps) * 6);
}
BENCHMARK(BM_EncoderDrive);

// The counters catching up (MuxedEncoder::run, the common case: within the
// filter's rate, no index armed), six moving, looked at every 50 us.
void BM_MuxedEncoderCatchUp(benchmark::State& state) {
  hm2::MuxedEncoder counters(6, kClockLow);
  for (unsigned i = 0; i < 6; ++i) counters.setVelocity(i, 20'000.0 + 30'000.0 * i, SimTime{0});
  SimTime t{0};
  std::uint32_t sum = 0;
  for (auto _ : state) {
    t += kPlantStep;
    counters.advance(t);
    for (unsigned i = 0; i < 6; ++i) sum += counters.count(i);
  }
  benchmark::DoNotOptimize(sum);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * 6);
}
BENCHMARK(BM_MuxedEncoderCatchUp);

// One axis over a servo period, solved exactly (ServoMotion: the mill's
// X, a velocity-mode drive, 150 kg on a 5 mm screw), the command changing
// every period as a position loop's does; per iteration one period.
void BM_ServoMotionPeriod(benchmark::State& state) {
  machine::ServoAmplifier amplifier(machine::AmplifierParameters{});
  machine::AxisParameters p;
  p.inertia = 1.5e-4 + 1e-4 + machine::reflectedInertia(150.0, 5.0);
  machine::Axis axis(p, 200.0);
  machine::ServoMotion motion;
  std::uint64_t n = 0;
  for (auto _ : state) {
    machine::ServoDrive drive{&amplifier, 1.0 + static_cast<double>(n % 200) / 1000.0, true, p.inertia, 0.0};
    motion.advance(axis, std::span(&drive, 1), false, kPlantStep);
    ++n;
  }
  benchmark::DoNotOptimize(axis.position());
  state.counters["events"] = static_cast<double>(motion.events());
}
BENCHMARK(BM_ServoMotionPeriod);

// The same axis and commands over a period by the fixed-step integrator
// the tests compare the exact solution with (tests/support/fixed_step_plant.hpp),
// at the 50 us step the plant once took: what one period of one axis cost
// before, beside what it costs now.
void BM_FixedStepPeriod(benchmark::State& state) {
  machine::AxisParameters p;
  p.inertia = 1.5e-4 + 1e-4 + machine::reflectedInertia(150.0, 5.0);
  test_support::FixedStepAxis axis(p, {{machine::AmplifierParameters{}, p.inertia}}, 200.0);
  const std::vector<bool> ena{true};
  std::vector<double> volts{0.0};
  std::uint64_t n = 0;
  for (auto _ : state) {
    volts[0] = 1.0 + static_cast<double>(n % 200) / 1000.0;
    axis.run(volts, ena, false, 1e-3, 50e-6);
    ++n;
  }
  benchmark::DoNotOptimize(axis.position());
}
BENCHMARK(BM_FixedStepPeriod);

}  // namespace
