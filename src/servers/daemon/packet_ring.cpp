// SPDX-License-Identifier: MIT
#include "daemon/packet_ring.hpp"

#include <stdexcept>

namespace lbpkit::server {

PacketRing::PacketRing(std::size_t slots) : capacity_(slots) {
  if (capacity_ == 0) throw std::invalid_argument("a packet ring needs room for packets");
  slots_ = std::make_unique<Slot[]>(capacity_);
}

PacketRing::Slot* PacketRing::claim() {
  const std::uint64_t head = head_.load(std::memory_order_relaxed);
  if (head - tail_.load(std::memory_order_acquire) >= capacity_) {
    dropped_.fetch_add(1, std::memory_order_relaxed);
    return nullptr;
  }
  return &slots_[head % capacity_];
}

void PacketRing::commit() { head_.store(head_.load(std::memory_order_relaxed) + 1, std::memory_order_release); }

}  // namespace lbpkit::server
