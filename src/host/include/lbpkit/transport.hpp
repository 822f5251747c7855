// SPDX-License-Identifier: MIT
// How the host library reaches a HostMot2 card's 32-bit registers.
//
// Accesses are queued and sent by flush() or tryFlush(), in order, in as few
// exchanges as the transport allows (one LBP16 datagram each way on
// Ethernet; direct register accesses for the in-process virtual card). Reads
// land in the caller's buffers when the flush returns. The queue has a fixed
// capacity, so a cycle never allocates.
//
// Two ways to flush, because a reply that does not come means different
// things at different times: at set-up (reading the IDROM, discovery,
// commands) the card must answer, and flush() throws lbpkit::Error when it
// does not. In the real-time cycle a lost or late datagram is an expected
// event on any network: tryFlush() reports it and counts it, without
// throwing or allocating, and the caller carries on with its last good data
// (as LinuxCNC's hm2_eth treats a temporary read failure).
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>

namespace lbpkit {

using Nanoseconds = std::chrono::nanoseconds;

class Transport {
 public:
  // What the link lost, since the transport was made.
  struct LinkCounters {
    std::uint64_t lostReplies = 0;   // exchanges whose reply did not come in time
    std::uint64_t discarded = 0;     // late replies and stray datagrams thrown away
    std::uint64_t sendFailures = 0;  // requests that could not be sent (or were refused: nothing listening)
    // Exchanges that failed: a read queued before one of them may not have
    // its data.
    [[nodiscard]] std::uint64_t failedExchanges() const { return lostReplies + sendFailures; }
  };

  virtual ~Transport() = default;

  virtual void queueRead(std::uint16_t address, std::uint32_t* into, std::size_t count = 1) = 0;
  virtual void queueWrite(std::uint16_t address, const std::uint32_t* from, std::size_t count = 1) = 0;
  // Sends what is queued; returns when every queued read has its data.
  // Throws lbpkit::Error when the card does not answer (set-up).
  virtual void flush() = 0;
  // The cycle's flush: sends what is queued and waits at most the
  // transport's cycle timeout for each reply. Returns false when an exchange
  // failed (counted in linkCounters()): the reads of that exchange keep what
  // their buffers held before. Never throws, never allocates.
  [[nodiscard]] virtual bool tryFlush() = 0;
  [[nodiscard]] virtual LinkCounters linkCounters() const = 0;

  // Time as the card sees it: simulated for the in-process card, the
  // monotonic clock for a real one. sleep() lets it pass.
  virtual Nanoseconds now() = 0;
  virtual void sleep(Nanoseconds d) = 0;

  // Round trips so far (datagram exchanges, or flushes in process).
  [[nodiscard]] virtual std::uint64_t exchanges() const = 0;
  [[nodiscard]] virtual std::string describe() const = 0;

  // Conveniences: one register, flushed at once.
  std::uint32_t read32(std::uint16_t address) {
    std::uint32_t v = 0;
    queueRead(address, &v);
    flush();
    return v;
  }
  void write32(std::uint16_t address, std::uint32_t value) {
    queueWrite(address, &value);
    flush();
  }
};

}  // namespace lbpkit
