// SPDX-License-Identifier: MIT
// On the host clock, the watch a card keeps on its host's process: is a
// host that has not cycled for a while late or stopped (docs/clocks.md)?
//
// A thread of its own looks, every kLook, while the host has been silent
// for more than kLook: it finds the process that holds the socket the
// host's cycles come from (process::udpSocketOwner) and reads its threads'
// states (process::threadsState). A sighting of it runnable is handed to
// the card thread through an atomic, which SimClock::hostRunning() takes;
// the card thread never reads /proc itself, allocates or waits for this
// one. Where the process cannot be found (another network namespace, a
// set-user-ID host and a sim without root) nothing is ever sighted, and
// the clock's silence rule is as without the watch.
#pragma once

#include <netinet/in.h>
#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <thread>

namespace lbpkit::server {

class HostWatch {
 public:
  using Clock = std::chrono::steady_clock;
  HostWatch();
  ~HostWatch();
  HostWatch(const HostWatch&) = delete;
  HostWatch& operator=(const HostWatch&) = delete;

  // Card thread: the host completed a cycle, its DoIt from `peer`, now.
  void cycled(const sockaddr_in& peer);
  // Card thread: when the host was last seen runnable (Clock's time since
  // its epoch), or zero.
  [[nodiscard]] Clock::duration runningAt() const { return Clock::duration{runningAt_.load()}; }
  // The host's process (its PID in this process's PID namespace), or 0
  // while not found.
  [[nodiscard]] pid_t pid() const { return pid_.load(); }

  // How often the watch looks, and how long a host is silent before it
  // does: well under the clock's 40 ms silence, so a late host is seen
  // runnable several times before that.
  static constexpr std::chrono::milliseconds kLook{5};
  // How often a host whose process was not found is looked for again.
  static constexpr std::chrono::seconds kFindAgain{1};

 private:
  void run(const std::stop_token& stop);

  std::atomic<std::uint64_t> peer_{0};  // address << 16 | port of the last cycle's DoIt, 0: none yet
  std::atomic<Clock::rep> lastCycle_{0};
  std::atomic<Clock::rep> runningAt_{0};
  std::atomic<pid_t> pid_{0};
  std::jthread thread_;
};

}  // namespace lbpkit::server
