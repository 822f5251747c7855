// How the host library reaches a HostMot2 card's 32-bit registers.
//
// Accesses are queued and sent by flush(), in order, in as few exchanges as
// the transport allows (one LBP16 datagram each way on Ethernet; direct
// register accesses for the in-process virtual card). Reads land in the
// caller's buffers when flush() returns. The queue has a fixed capacity, so
// a cycle never allocates.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>

namespace lbpkit {

using Nanoseconds = std::chrono::nanoseconds;

class Transport {
 public:
  virtual ~Transport() = default;

  virtual void queueRead(std::uint16_t address, std::uint32_t* into, std::size_t count = 1) = 0;
  virtual void queueWrite(std::uint16_t address, const std::uint32_t* from, std::size_t count = 1) = 0;
  // Sends what is queued; returns when every queued read has its data.
  // Throws lbpkit::Error when the card does not answer.
  virtual void flush() = 0;

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
