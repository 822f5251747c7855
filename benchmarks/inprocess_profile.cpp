// SPDX-License-Identifier: MIT
// Runs the in-process scenario (lbpkit::MillClosedLoop,
// src/adapters/sim_card/mill_closed_loop.hpp) for a fixed
// number of 1 kHz cycles, for a profiler: instruction counts under
// callgrind are the same every run, wall time on a shared machine is not.
//
//   valgrind --tool=callgrind --collect-atstart=no --toggle-collect='lbpkit_bench::runCycles*'
//     build/<dir>/benchmarks/lbpkit_inprocess_profile 5000
//
// collects only the cycles (not discovery); the total over the cycles is
// the figure. Without valgrind it prints the CPU time per simulated ms.
// `check` as the third argument also prints a hash of what every cycle
// saw (the host's counts and velocities of the 7I77's six encoders, the axes and the spindle, bit for
// bit): a change meant to be only faster must leave it as it was.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>

#include "sim_card/mill_closed_loop.hpp"

namespace lbpkit_bench {

// Out of line, so that callgrind can collect exactly this.
[[gnu::noinline]] void runCycles(lbpkit::MillClosedLoop& mill, std::uint64_t cycles) {
  for (std::uint64_t i = 0; i < cycles; ++i) mill.cycle();
}

}  // namespace lbpkit_bench

namespace {
// FNV-1a over the bytes of each value.
struct Hash {
  std::uint64_t h = 1469598103934665603ULL;
  template <typename T>
  void add(const T& v) {
    unsigned char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    for (unsigned char c : b) h = (h ^ c) * 1099511628211ULL;
  }
};

std::uint64_t checkedRun(lbpkit::MillClosedLoop& mill, std::uint64_t cycles) {
  Hash hash;
  for (std::uint64_t i = 0; i < cycles; ++i) {
    mill.cycle();
    const auto& e = mill.encoders();
    // The six counters the 7I77 carries (the firmware's other six, for a
    // second 7I77, are not read: num_encoders=6).
    for (unsigned n = 0; n < 6; ++n) {
      hash.add(e.counts(n));
      hash.add(e.velocity(n));
      hash.add(e.control(n));
    }
    const auto& m = mill.machine();
    for (std::size_t a = 0; a < m.axes(); ++a) {
      hash.add(m.axis(a).position());
      hash.add(m.axis(a).velocity());
    }
    hash.add(m.spindle()->revolutions());
    hash.add(mill.status().freshMask);
  }
  return hash.h;
}

double cpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}
}  // namespace

int main(int argc, char** argv) {
  const long cycles = argc > 1 ? std::atol(argv[1]) : 5000;
  const long stepUs = argc > 2 ? std::atol(argv[2]) : 1000;
  const bool check = argc > 3 && std::strcmp(argv[3], "check") == 0;
  if (cycles <= 0 || stepUs <= 0 || (argc > 3 && !check)) {
    std::fprintf(stderr, "usage: lbpkit_inprocess_profile [CYCLES (5000)] [PLANT_SPAN_US (1000)] [check]\n");
    return 2;
  }
  lbpkit::MillClosedLoop mill{std::chrono::microseconds(stepUs)};
  const double t0 = cpuSeconds();
  std::uint64_t hash = 0;
  if (check)
    hash = checkedRun(mill, static_cast<std::uint64_t>(cycles));
  else
    lbpkit_bench::runCycles(mill, static_cast<std::uint64_t>(cycles));
  const double cpu = cpuSeconds() - t0;
  const double simulated = mill.simulatedSeconds();
  std::printf("%ld cycles, %.3f simulated s, %.3f CPU s: %.3f us CPU per simulated ms, %.0f x real time\n", cycles,
              simulated, cpu, cpu / simulated * 1e3, simulated / cpu);
  // What the run ended at, so a change that alters behaviour shows here too.
  const auto& m = mill.machine();
  std::printf("axes:");
  for (std::size_t a = 0; a < m.axes(); ++a) std::printf(" %.9f", m.axis(a).position());
  std::printf("  spindle: %.9f revs  status ok=%d fresh=0x%x\n", m.spindle()->revolutions(),
              mill.status().ok ? 1 : 0, mill.status().freshMask);
  if (check) std::printf("check: %016llx\n", static_cast<unsigned long long>(hash));
  return mill.status().ok ? 0 : 1;
}
