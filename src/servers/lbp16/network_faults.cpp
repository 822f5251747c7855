#include "lbp16/network_faults.hpp"

namespace servers {

void NetworkFaults::set(const NetworkFaultSettings& s) {
  settings_ = s;
  // A new setting starts its own repeatable sequence: the same script with
  // the same seed loses the same datagrams.
  random_.seed(s.seed);
  seen_[0] = seen_[1] = 0;
}

NetworkFaults::Fate NetworkFaults::decide(Kind kind, std::size_t size, Clock::time_point now) {
  Fate f;
  auto& c = counters(kind);
  const Dir& d = kind == Kind::Request ? settings_.request : settings_.reply;
  const std::uint64_t n = ++seen_[kind == Kind::Request ? 0 : 1];
  if (now < silentUntil_) {
    ++c.silenced;
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
  if (d.delayUs > 0 || d.jitterUs > 0) {
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

}  // namespace servers
