// SPDX-License-Identifier: MIT
#include "lbp16/network_faults.hpp"

#include "lbpkit/wire/lbp16.hpp"

namespace lbpkit::server {

void NetworkFaults::set(const NetworkFaultSettings& s) {
  settings_ = s;
  // A new setting starts its own repeatable sequence: the same script with
  // the same seed loses the same datagrams.
  random_.seed(s.seed);
  seen_[0] = seen_[1] = 0;
}

NetworkFaults::Fate NetworkFaults::decide(Kind kind, std::size_t size, Clock::time_point now, bool asksForReply) {
  Fate f;
  auto& c = counters(kind);
  Dir& d = kind == Kind::Request ? settings_.request : settings_.reply;
  if (now < silentUntil_) {
    ++c.silenced;
    f.lost = true;
    return f;
  }
  if (kind == Kind::Request && d.writesOnly && asksForReply) {
    ++c.passed;
    return f;
  }
  const std::uint64_t n = ++seen_[kind == Kind::Request ? 0 : 1];
  if (d.dropNext > 0) {
    --d.dropNext;
    ++c.dropped;
    f.lost = true;
    return f;
  }
  if ((d.dropEvery > 0 && n % d.dropEvery == 0) || chance(d.drop)) {
    ++c.dropped;
    f.lost = true;
    return f;
  }
  ++c.passed;
  if (chance(d.duplicate)) {
    ++c.duplicated;
    f.copies = 2;
  }
  if (size > 0 && chance(d.corrupt)) {
    ++c.corrupted;
    f.corruptAt = static_cast<int>(static_cast<double>(size) * uniform_(random_)) % static_cast<int>(size);
  }
  if ((d.delayUs > 0 || d.jitterUs > 0) && (d.delayEvery == 0 || n % d.delayEvery == 0)) {
    ++c.delayed;
    const double jitter = static_cast<double>(d.jitterUs) * uniform_(random_);
    f.delay = std::chrono::microseconds(d.delayUs + static_cast<std::uint32_t>(jitter));
  }
  if (chance(d.reorder)) {
    ++c.reordered;
    f.holdBehindNext = true;
  }
  return f;
}

bool NetworkFaults::asksForReply(std::span<const std::uint8_t> request) {
  namespace lbp16 = lbpkit::wire::lbp16;
  std::size_t at = 0;
  while (at + 2 <= request.size()) {
    const auto command = lbp16::Command::decode(static_cast<std::uint16_t>(request[at] | (request[at + 1] << 8)));
    if (!command.write && command.count > 0) return true;
    at += 2 + (command.hasAddress ? 2 : 0) + (command.write ? command.dataBytes() : 0);
  }
  return false;
}

}  // namespace lbpkit::server
