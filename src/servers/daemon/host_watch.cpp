// SPDX-License-Identifier: MIT
#include "daemon/host_watch.hpp"

#include <arpa/inet.h>
#include <unistd.h>

#include "daemon/sim_clock.hpp"
#include "process/host_process.hpp"

namespace lbpkit::server {

HostWatch::HostWatch() : thread_([this](const std::stop_token& stop) { run(stop); }) {}

HostWatch::~HostWatch() = default;  // the thread, last member, is stopped and joined first

void HostWatch::cycled(const sockaddr_in& peer) {
  const std::uint64_t key = (static_cast<std::uint64_t>(peer.sin_addr.s_addr) << 16) | ntohs(peer.sin_port);
  if (peer_.load(std::memory_order_relaxed) != key) peer_.store(key);
  lastCycle_.store(Clock::now().time_since_epoch().count());
}

void HostWatch::run(const std::stop_token& stop) {
  std::uint64_t found = 0;  // the peer pid_ belongs to
  Clock::time_point lookedFor{};
  while (!stop.stop_requested()) {
    std::this_thread::sleep_for(kLook);
    if (stop.stop_requested()) return;
    const std::uint64_t peer = peer_.load();
    if (peer == 0) continue;
    const auto now = Clock::now();
    if (peer != found && now - lookedFor >= kFindAgain) {
      lookedFor = now;
      auto owner =
          process::udpSocketOwner(static_cast<std::uint32_t>(peer >> 16), static_cast<std::uint16_t>(peer & 0xFFFF));
      // A host in the sim's own process (a test's, a benchmark's) cannot
      // be told apart from the card thread and this one, always runnable.
      if (owner && *owner == ::getpid()) owner.reset();
      pid_.store(owner ? *owner : 0);
      if (owner) found = peer;
    }
    const pid_t pid = pid_.load();
    if (pid == 0 || peer != found) continue;
    const auto silent = now - Clock::time_point{Clock::duration{lastCycle_.load()}};
    if (silent < kLook || silent > SimClock::kRunningHostBound) continue;
    switch (process::threadsState(pid)) {
      case process::ThreadsState::Runnable: runningAt_.store(now.time_since_epoch().count()); break;
      case process::ThreadsState::Gone:
        pid_.store(0);
        found = 0;
        break;
      default: break;
    }
  }
}

}  // namespace lbpkit::server
