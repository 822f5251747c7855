// SPDX-License-Identifier: MIT
// What the card saw and sent, on its way to a capture file: a ring of
// fixed-size packet slots, allocated once, filled by one thread (the card
// thread, or the pty remote's) and emptied by another (pcap_recorder.hpp).
//
// The writer never waits and never allocates: when the reader is a whole
// ring behind, the packet is dropped and counted, never the writer delayed.
// A single-producer single-consumer queue: the writer owns `head_`, the
// reader `tail_`, each slot is handed over by a release store of the index.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <span>

namespace lbpkit::server {

class PacketRing {
 public:
  // Room for a 2048-byte datagram (UdpServer::kBuffer) behind IPv4 and UDP
  // headers; a longer packet keeps its first kSlotBytes (its length says how
  // long it was).
  static constexpr std::size_t kSlotBytes = 2048 + 28;
  struct Slot {
    std::int64_t ns = 0;      // CLOCK_REALTIME, nanoseconds
    std::uint32_t length = 0;  // the packet's whole length
    std::uint32_t captured = 0;  // of which in `bytes`
    std::uint8_t bytes[kSlotBytes];
  };

  explicit PacketRing(std::size_t slots);

  // The writer: the slot to fill, or nullptr when the ring is full (the
  // packet is counted as dropped). commit() hands it to the reader.
  Slot* claim();
  void commit();

  // The reader: calls `take(const Slot&)` for every committed slot, oldest
  // first, and frees them.
  template <typename Take>
  void drain(Take&& take) {
    const std::uint64_t head = head_.load(std::memory_order_acquire);
    std::uint64_t tail = tail_.load(std::memory_order_relaxed);
    for (; tail < head; ++tail) {
      take(static_cast<const Slot&>(slots_[tail % capacity_]));
      tail_.store(tail + 1, std::memory_order_release);
    }
  }

  [[nodiscard]] std::uint64_t dropped() const { return dropped_.load(std::memory_order_relaxed); }
  [[nodiscard]] std::size_t capacity() const { return capacity_; }

 private:
  std::size_t capacity_;
  std::unique_ptr<Slot[]> slots_;
  std::atomic<std::uint64_t> head_{0};  // slots committed
  std::atomic<std::uint64_t> tail_{0};  // slots taken
  std::atomic<std::uint64_t> dropped_{0};
};

}  // namespace lbpkit::server
