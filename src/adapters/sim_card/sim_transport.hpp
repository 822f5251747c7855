// SPDX-License-Identifier: MIT
// The in-process virtual card as a Transport: direct register accesses in
// simulated time (each access advances it, like a PCI read), so a whole
// machine runs deterministically and faster than real time.
#pragma once

#include <array>
#include <cstdint>
#include <memory>

#include "hostmot2/card.hpp"
#include "lbpkit/transport.hpp"

namespace lbpkit {

class SimTransport final : public Transport {
 public:
  static constexpr std::size_t kMaxQueued = 512;
  explicit SimTransport(model::hm2::HostMot2Card& card, Nanoseconds accessTime = Nanoseconds{500});
  // Owns its card (by default a 7I92 with one 7I77).
  explicit SimTransport(model::hm2::HostMot2Card::Options options = {}, Nanoseconds accessTime = Nanoseconds{500});

  void queueRead(std::uint16_t address, std::uint32_t* into, std::size_t count = 1) override;
  void queueWrite(std::uint16_t address, const std::uint32_t* from, std::size_t count = 1) override;
  void flush() override;
  [[nodiscard]] bool tryFlush() override;
  [[nodiscard]] LinkCounters linkCounters() const override { return counters_; }
  Nanoseconds now() override { return now_; }
  void sleep(Nanoseconds d) override;
  [[nodiscard]] std::uint64_t exchanges() const override { return exchanges_; }
  [[nodiscard]] std::string describe() const override { return "in-process virtual 7I92 with 7I77"; }

  model::hm2::HostMot2Card& card() { return card_; }
  // Simulated network round trip added to every flush (0: a local bus).
  void setExchangeLatency(Nanoseconds d) { exchangeLatency_ = d; }

  // Test hook: the replies of the next `n` exchanges that carry reads are
  // lost on the way back, as on a network. The card still does every access
  // (its reads too: a read can have side effects); the caller's buffers keep
  // what they held, tryFlush() returns false and flush() throws. A lost
  // reply costs the host `lostReplyWait` of simulated time (its timeout).
  void dropNextReplies(unsigned n) { dropReplies_ = n; }
  void setLostReplyWait(Nanoseconds d) { lostReplyWait_ = d; }

 private:
  // Runs the queue against the card; false when its reply was dropped.
  bool run();
  struct Op {
    bool write;
    std::uint16_t address;
    std::uint32_t* into;
    std::uint32_t value;
  };
  std::unique_ptr<model::hm2::HostMot2Card> owned_;
  model::hm2::HostMot2Card& card_;
  Nanoseconds accessTime_;
  Nanoseconds now_{0};
  Nanoseconds exchangeLatency_{0};
  Nanoseconds lostReplyWait_{std::chrono::microseconds(500)};
  std::array<Op, kMaxQueued> ops_{};
  std::size_t queued_ = 0;
  std::uint64_t exchanges_ = 0;
  unsigned dropReplies_ = 0;
  bool pendingLoss_ = false;  // a full queue's exchange lost its reply, for the next flush to report
  LinkCounters counters_{};
};

}  // namespace lbpkit
