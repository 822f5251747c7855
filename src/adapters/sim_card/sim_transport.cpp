// SPDX-License-Identifier: MIT
#include "sim_card/sim_transport.hpp"

#include "lbpkit/error.hpp"

namespace lbpkit {

SimTransport::SimTransport(model::hm2::HostMot2Card& card, Nanoseconds accessTime)
    : card_(card), accessTime_(accessTime) {}

SimTransport::SimTransport(model::hm2::HostMot2Card::Options options, Nanoseconds accessTime)
    : owned_(std::make_unique<model::hm2::HostMot2Card>(std::move(options))), card_(*owned_), accessTime_(accessTime) {}

void SimTransport::queueRead(std::uint16_t address, std::uint32_t* into, std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) {
    if (queued_ == ops_.size() && !run()) pendingLoss_ = true;
    ops_[queued_++] = Op{false, static_cast<std::uint16_t>(address + 4 * i), into + i, 0};
  }
}

void SimTransport::queueWrite(std::uint16_t address, const std::uint32_t* from, std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) {
    if (queued_ == ops_.size() && !run()) pendingLoss_ = true;
    ops_[queued_++] = Op{true, static_cast<std::uint16_t>(address + 4 * i), nullptr, from[i]};
  }
}

bool SimTransport::run() {
  bool reads = false;
  for (std::size_t i = 0; i < queued_ && !reads; ++i) reads = !ops_[i].write;
  const bool drop = reads && dropReplies_ > 0;
  if (drop) --dropReplies_;
  if (queued_) now_ += exchangeLatency_ / 2;  // the request's way there
  for (std::size_t i = 0; i < queued_; ++i) {
    const Op& op = ops_[i];
    now_ += accessTime_;
    if (op.write) {
      card_.write32(op.address, op.value, now_);
    } else {
      const std::uint32_t v = card_.read32(op.address, now_);
      if (!drop) *op.into = v;
    }
  }
  if (queued_) {
    ++exchanges_;
    if (drop) {
      now_ += lostReplyWait_;  // the host waits out its timeout
      ++counters_.lostReplies;
    } else {
      now_ += exchangeLatency_ / 2;  // and the reply's way back
    }
  }
  queued_ = 0;
  return !drop;
}

void SimTransport::flush() {
  const bool lost = !run() || pendingLoss_;
  pendingLoss_ = false;
  if (lost) throw Error(describe() + ": reply lost (simulated)");
}

bool SimTransport::tryFlush() {
  const bool ok = run() && !pendingLoss_;
  pendingLoss_ = false;
  return ok;
}

void SimTransport::sleep(Nanoseconds d) {
  now_ += d;
  card_.advance(now_);
}

}  // namespace lbpkit
