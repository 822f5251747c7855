// SPDX-License-Identifier: MIT
// A HostMot2 card on the network: LBP16 over UDP (Mesa 7I92 and kin). A
// flush sends everything queued as one datagram (more only past 1400 bytes,
// the limit hm2_eth keeps to) and waits for the one reply holding every
// read, in order.
//
// A datagram with reads also writes a sequence number to the card's timer
// space scratch word and reads it back last (as hm2_eth does with its packet
// counters), so a reply that comes after its exchange timed out is told
// apart from the one awaited even when both have the same length: it is
// discarded and counted, never taken for fresh data.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "lbpkit/transport.hpp"

namespace lbpkit {

class Lbp16Transport final : public Transport {
 public:
  static constexpr std::size_t kMaxDatagram = 1400;
  static constexpr std::uint16_t kPort = 27181;
  // How long tryFlush() waits for a reply unless told otherwise: a healthy
  // card answers within a few hundred microseconds; this is long enough for
  // a busy host, short enough that a lost datagram costs a few servo periods.
  static constexpr Nanoseconds kDefaultCycleTimeout = std::chrono::milliseconds(5);

  // `timeout`: how long flush() (set-up) waits for a reply before it throws.
  explicit Lbp16Transport(const std::string& address, std::uint16_t port = kPort,
                          Nanoseconds timeout = std::chrono::milliseconds(200));
  ~Lbp16Transport() override;
  Lbp16Transport(const Lbp16Transport&) = delete;
  Lbp16Transport& operator=(const Lbp16Transport&) = delete;

  void queueRead(std::uint16_t address, std::uint32_t* into, std::size_t count = 1) override;
  void queueWrite(std::uint16_t address, const std::uint32_t* from, std::size_t count = 1) override;
  void flush() override;
  [[nodiscard]] bool tryFlush() override;
  [[nodiscard]] LinkCounters linkCounters() const override { return counters_; }
  Nanoseconds now() override;
  void sleep(Nanoseconds d) override;
  [[nodiscard]] std::uint64_t exchanges() const override { return exchanges_; }
  [[nodiscard]] std::string describe() const override;

  // How long tryFlush() waits for each reply (the cycle's reply timeout).
  void setCycleTimeout(Nanoseconds d) { cycleTimeout_ = d; }
  [[nodiscard]] Nanoseconds cycleTimeout() const { return cycleTimeout_; }

  // One raw LBP16 request expecting `replyBytes` back (other memory spaces).
  std::vector<std::uint8_t> request(std::span<const std::uint8_t> datagram, std::size_t replyBytes);
  // The name in the board-info space ("7I92").
  std::string boardName();

 private:
  enum class Outcome : std::uint8_t { Ok, Lost, SendFailed, Refused };
  // Sends out_ and waits up to `timeout` for its reply; counts what fails.
  // `tagged`: append the sequence write and read-back (datagrams with reads).
  Outcome exchange(Nanoseconds timeout, bool tagged);
  // A queue that is full is sent on the way (with the timeout of the last
  // explicit flush's kind); a failure is kept for that flush to report.
  void sendFull();
  [[noreturn]] void throwFor(Outcome o, Nanoseconds timeout) const;

  struct PendingRead {
    std::uint32_t* into;
    std::size_t count;
  };
  int fd_ = -1;
  std::string address_;
  std::uint16_t port_;
  Nanoseconds timeout_;
  Nanoseconds cycleTimeout_ = kDefaultCycleTimeout;
  std::array<std::uint8_t, kMaxDatagram> out_{};
  std::size_t outLen_ = 0;
  std::array<PendingRead, 256> reads_{};
  std::size_t readCount_ = 0;
  std::size_t replyLen_ = 0;
  std::array<std::uint8_t, 2048> in_{};
  std::uint64_t exchanges_ = 0;
  std::uint16_t sequence_ = 0;
  LinkCounters counters_{};
  bool cycleMode_ = false;          // the last explicit flush was tryFlush()
  Outcome pending_ = Outcome::Ok;   // first failure of a full queue's exchange, for the next flush
  Nanoseconds pendingTimeout_{};    // and the timeout it had
  int errno_ = 0;                   // errno of the last failed send
  std::chrono::steady_clock::time_point start_;
};

}  // namespace lbpkit
