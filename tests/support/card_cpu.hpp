// SPDX-License-Identifier: MIT
// The CPU a real client (mesaflash, LinuxCNC's rtapi_app) shares with the
// sim's card thread (`lbpkit sim --cpu N`). The clients give the card a few
// milliseconds of the wall clock: mesaflash's discovery sleeps 2 ms and then
// looks once (mesaflash: eth_boards.c), hm2_eth's set-up gives each read
// 1.6 ms (LinuxCNC: hm2_eth.c). On two CPUs of a virtual machine, a card
// thread on the other CPU may not run for longer than that when the host
// machine holds that CPU back, however high its priority. On the client's
// own CPU the card thread (SCHED_FIFO, above the client) is woken by the
// client's datagram and runs before the client does again: the reply is in
// the socket before the client looks for it, however the machine is
// scheduled, as a real card's reply is.
#pragma once

#include <string>
#include <vector>

#include "process/process.hpp"

namespace test_support {

// The CPUs this test may run on, ascending.
inline std::vector<unsigned> allowedCpus() { return lbpkit::process::allowedCpus(); }

// The card's CPU: the last this test may use, or the `k`-th before it (two
// cards and their clients side by side on two CPUs).
inline unsigned cardCpu(unsigned k = 0) {
  const auto cpus = allowedCpus();
  if (cpus.empty()) return 0;
  return cpus[cpus.size() - 1 - k % cpus.size()];
}

// `lbpkit sim` options with its card thread on `cpu` first (--cpu N).
inline std::vector<std::string> withCardCpu(std::vector<std::string> options, unsigned cpu = cardCpu()) {
  options.insert(options.begin(), {"--cpu", std::to_string(cpu)});
  return options;
}

// A shell command's prefix that runs it, and all it starts, on `cpu`.
inline std::string onCpu(unsigned cpu) { return "taskset -c " + std::to_string(cpu) + " "; }

// This process (a child before its exec) on `cpu` alone.
inline void runOnCpu(unsigned cpu) { (void)lbpkit::process::pinToCpu(cpu); }

}  // namespace test_support
