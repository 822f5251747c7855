// SPDX-License-Identifier: MIT
// The RS-422 link between an SSLBP channel and an LBP remote: characters at
// the channel's baud rate, so an exchange takes the time its characters take
// on the wire plus the remote's turnaround (manual: SSLBP, DOIT; LBP, FRAMING).
//
// The link can be cut, and can corrupt, drop or add characters, or carry a
// break, in either direction, for fault injection: SSLBP then reports what
// a real card would (CS REGISTER AFTER START, local fault bits).
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "lbp/sim_time.hpp"
#include "remote/remote_device.hpp"

namespace lbpkit::model::hm2 {

using lbp::SimTime;

class SerialLink {
 public:
  // Time from the remote's last received character to its first reply
  // character: parser and RPC processing on the remote's processor.
  static constexpr SimTime kTurnaround = SimTime{2000};  // 2 us
  static constexpr std::size_t kMaxReply = 300;

  enum class Direction { ToRemote, FromRemote };

  void attach(remote::RemoteDevice* remote) { remote_ = remote; }
  [[nodiscard]] remote::RemoteDevice* remote() const { return remote_; }

  struct Reply {
    // The first `size` bytes are the reply; the rest are not set (not
    // cleared either: an exchange runs for every SSLBP transaction).
    std::array<std::uint8_t, kMaxReply> bytes;
    std::size_t size = 0;
    SimTime lastByteAt{};  // when the last reply character has arrived
    bool breakSeen = false;
  };
  // Sends `frame` starting at `start` at `baud` and collects what comes back.
  // On an external link the frame goes to the outbox and no reply comes back.
  Reply exchange(std::span<const std::uint8_t> frame, SimTime start, std::uint32_t baud);

  // --- External remote (lbpkit sim --remote CH=pty) ------------------------
  // The remote is another process: frames the channel sends wait in a fixed
  // outbox (no allocation per frame) until whoever serves the process takes
  // them; its reply comes back through Sslbp::remoteBytes. Fault
  // injection applies to the frames sent; replies arrive as they are.
  static constexpr std::size_t kOutboxSize = 1024;
  void setExternal(bool external) {
    external_ = external;
    outboxSize_ = 0;
  }
  [[nodiscard]] bool external() const { return external_; }
  [[nodiscard]] std::span<const std::uint8_t> outbox() const { return {outbox_.data(), outboxSize_}; }
  // The first `count` outbox bytes have been taken.
  void consumeOutbox(std::size_t count);

  // --- Fault injection -------------------------------------------------------
  void setConnected(bool connected) { connected_ = connected; }
  [[nodiscard]] bool connected() const { return connected_; }
  // The next `count` characters in `dir` are damaged (bits flipped) or
  // dropped; `addExtra` puts noise characters right after the next frame or
  // reply; a break is a framing error on the next reply.
  void corruptNext(Direction dir, unsigned count = 1) { faults(dir).corrupt += count; }
  void dropNext(Direction dir, unsigned count = 1) { faults(dir).drop += count; }
  void addExtra(Direction dir, unsigned count = 1) { faults(dir).add += count; }
  void breakNext() { breakNext_ = true; }

  // Faults at a rate, as a noisy cable makes them: each of a
  // character's 8 data bits flipped with probability `bitErrorRate`; a
  // character lost with `dropRate`; a noise character after one with
  // `extraRate`; a reply ending in a break with `breakRate`. Drawn from the
  // link's own generator, seeded, so a run repeats exactly. Start and stop
  // bits are not flipped: what a receiver makes of a lost stop bit (a
  // framing error) is the break's to show.
  struct Rates {
    double bitErrorRate = 0;
    double dropRate = 0;
    double extraRate = 0;
    bool operator==(const Rates&) const = default;
  };
  struct RateSettings {
    Rates toRemote;
    Rates fromRemote;
    double breakRate = 0;  // per reply
    std::uint64_t seed = 1;
    bool operator==(const RateSettings&) const = default;
  };
  // Takes effect from the next character; restarts the generator from `seed`.
  void setRates(const RateSettings& settings);
  [[nodiscard]] const RateSettings& rates() const { return rates_; }
  // The cable pulled at `from` and plugged back at `until` (simulated time):
  // nothing crosses in between. Replaces an earlier cut.
  void cut(SimTime from, SimTime until) {
    cutFrom_ = from;
    cutUntil_ = until;
  }
  [[nodiscard]] SimTime cutUntil() const { return cutUntil_; }
  // Connected, and not within a cut, at `t`.
  [[nodiscard]] bool connectedAt(SimTime t) const { return connected_ && (t < cutFrom_ || t >= cutUntil_); }

  struct Counters {
    std::uint64_t toRemote = 0;
    std::uint64_t fromRemote = 0;
    std::uint64_t corrupted = 0;  // characters damaged (one bit or more)
    std::uint64_t bitErrors = 0;  // bits flipped by the bit error rate
    std::uint64_t dropped = 0;
    std::uint64_t added = 0;
    std::uint64_t breaks = 0;
    std::uint64_t outboxOverflows = 0;  // external: bytes lost, nobody took the outbox
  };
  [[nodiscard]] const Counters& counters() const { return counters_; }

 private:
  struct Faults {
    unsigned corrupt = 0;
    unsigned drop = 0;
    unsigned add = 0;
  };
  Faults& faults(Direction d) { return d == Direction::ToRemote ? toRemote_ : fromRemote_; }
  // Nothing can happen to a character of an exchange starting at `start`:
  // connected with no cut still to come, no fault pending or at a rate, no
  // break due. Then exchange() only carries characters (the common case,
  // every DOIT of a healthy link), with the same timing and counts.
  [[nodiscard]] bool clean(SimTime start) const {
    return connected_ && !external_ && !breakNext_ && noRates_ && cutUntil_ <= start &&
           (toRemote_.corrupt | toRemote_.drop | toRemote_.add | fromRemote_.corrupt | fromRemote_.drop |
            fromRemote_.add) == 0;
  }
  // Applies pending faults and the rates to one character; returns 0 when
  // it is lost.
  unsigned damage(Direction d, std::uint8_t& byte);
  // Noise characters to add after this frame.
  unsigned extras(Faults& f);
  // A noise character after this one (the extra rate)?
  bool extraAfter(Direction d);
  static constexpr std::uint8_t kNoise = 0xA5;

  // The rates' generator: splitmix64, small and exactly repeatable.
  std::uint64_t nextRandom();
  double uniform();  // [0, 1)
  // Bits until the next flipped one: geometric in the bit error rate.
  std::uint64_t bitsToNextError(double rate);
  struct RateState {
    std::uint64_t bitsToError = UINT64_MAX;
  };
  RateState& rateState(Direction d) { return d == Direction::ToRemote ? toRemoteRate_ : fromRemoteRate_; }
  const Rates& ratesOf(Direction d) const { return d == Direction::ToRemote ? rates_.toRemote : rates_.fromRemote; }

  remote::RemoteDevice* remote_ = nullptr;
  bool connected_ = true;
  bool external_ = false;
  std::array<std::uint8_t, kOutboxSize> outbox_{};
  std::size_t outboxSize_ = 0;
  bool breakNext_ = false;
  Faults toRemote_;
  Faults fromRemote_;
  RateSettings rates_;
  bool noRates_ = true;  // every rate of rates_ is 0 (set by setRates)
  std::uint64_t random_ = 1;
  RateState toRemoteRate_;
  RateState fromRemoteRate_;
  SimTime cutFrom_{0};
  SimTime cutUntil_{0};
  Counters counters_;
};

}  // namespace lbpkit::model::hm2
