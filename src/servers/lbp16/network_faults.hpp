// SPDX-License-Identifier: MIT
// A bad network between the host and the virtual card, on purpose:
// datagrams dropped, delayed, duplicated, reordered or damaged, per
// direction, and the cable pulled for a while.
//
// What a user rehearses with it is hm2_eth's side: a reply later than its
// `packet-read-timeout` (80 % of the servo period by default) or missing
// counts toward `packet-error-level`, and at `packet-error-limit` the driver
// sets `io_error` (LinuxCNC hostmot2(9), hm2_eth(9)). The card's own
// behaviour is untouched: what the card does with a request that arrives is
// what it always does.
//
// This is the network, so it keeps wall-clock time (the caller passes it
// in, so tests drive it by hand). Its per-datagram decisions take no locks
// and allocate nothing; the seed makes a run repeatable.
#pragma once

#include <chrono>
#include <cstdint>
#include <random>
#include <span>

namespace lbpkit::server {

struct NetworkFaultSettings {
  // One direction of the wire: requests (host -> card) or replies.
  struct Direction {
    double drop = 0;                // probability that a datagram is lost, 0..1
    std::uint32_t dropEvery = 0;    // and every Nth one (0: none)
    std::uint32_t dropNext = 0;     // and the next N, whatever else is set (counts down as they go)
    double duplicate = 0;           // probability that it arrives twice
    double corrupt = 0;             // probability that one of its bytes is damaged
    double reorder = 0;             // probability that it is held back behind the next one
    std::uint32_t delayUs = 0;      // every datagram arrives this much later
    std::uint32_t jitterUs = 0;     // plus up to this much more (uniform)
    std::uint32_t delayEvery = 0;   // the delay for every Nth datagram only, a spike (0: every one)
    bool writesOnly = false;        // requests: only those that ask for no reply (hm2_eth's writes)
    [[nodiscard]] bool active() const {
      return drop > 0 || dropEvery > 0 || dropNext > 0 || duplicate > 0 || corrupt > 0 || reorder > 0 ||
             delayUs > 0 || jitterUs > 0;
    }
    bool operator==(const Direction&) const = default;
  };
  Direction request;
  Direction reply;
  std::uint64_t seed = 1;
  bool operator==(const NetworkFaultSettings&) const = default;
};

struct NetworkFaultCounters {
  struct Direction {
    std::uint64_t passed = 0;      // went on (perhaps late or damaged)
    std::uint64_t dropped = 0;     // by `drop`, `dropEvery` or `dropNext`
    std::uint64_t silenced = 0;    // lost while the cable was out
    std::uint64_t duplicated = 0;
    std::uint64_t corrupted = 0;
    std::uint64_t reordered = 0;
    std::uint64_t delayed = 0;
    std::uint64_t overflowed = 0;  // no room to hold a delayed one: lost
  };
  Direction request;
  Direction reply;
};

class NetworkFaults {
 public:
  using Clock = std::chrono::steady_clock;
  using Dir = NetworkFaultSettings::Direction;

  NetworkFaults() { set(NetworkFaultSettings{}); }

  void set(const NetworkFaultSettings& s);
  [[nodiscard]] const NetworkFaultSettings& settings() const { return settings_; }
  // The cable out for `d` from `now` (a new call replaces the old one; 0
  // plugs it back at once).
  void silence(std::chrono::microseconds d, Clock::time_point now) { silentUntil_ = now + d; }
  [[nodiscard]] std::chrono::microseconds silentFor(Clock::time_point now) const {
    return now < silentUntil_ ? std::chrono::duration_cast<std::chrono::microseconds>(silentUntil_ - now)
                              : std::chrono::microseconds{0};
  }
  [[nodiscard]] const NetworkFaultCounters& counters() const { return counters_; }
  // Whether anything is set: when not, the server takes its plain path.
  [[nodiscard]] bool active(Clock::time_point now) const {
    return settings_.request.active() || settings_.reply.active() || now < silentUntil_;
  }

  enum class Kind : std::uint8_t { Request, Reply };
  // What happens to one datagram.
  struct Fate {
    bool lost = false;
    unsigned copies = 1;                 // 2: duplicated
    std::chrono::microseconds delay{0};  // hold it this long
    bool holdBehindNext = false;         // reordered: send after the next one
    int corruptAt = -1;                  // this byte is damaged (index into the datagram)
  };
  // Decides a datagram's fate (and counts it). `size` is its length;
  // `asksForReply`: a request that holds a read (see asksForReply below).
  Fate decide(Kind kind, std::size_t size, Clock::time_point now, bool asksForReply = true);
  // Whether an LBP16 request holds a read command, so that the card answers
  // it; hm2_eth's writes (a datagram of write commands) do not.
  static bool asksForReply(std::span<const std::uint8_t> request);
  // Damages one byte as a bad link would: a few bits flipped.
  static void damage(std::uint8_t& byte) { byte ^= 0x24; }
  void countOverflow(Kind kind) { ++counters(kind).overflowed; }

 private:
  NetworkFaultCounters::Direction& counters(Kind k) {
    return k == Kind::Request ? counters_.request : counters_.reply;
  }
  bool chance(double p) { return p > 0 && (p >= 1 || uniform_(random_) < p); }

  NetworkFaultSettings settings_;
  NetworkFaultCounters counters_;
  std::uint64_t seen_[2] = {0, 0};  // datagrams per direction that the settings apply to, for the every-Nth ones
  Clock::time_point silentUntil_{};
  std::mt19937_64 random_;
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};
};

}  // namespace lbpkit::server
