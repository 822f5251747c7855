// SPDX-License-Identifier: MIT
#include "hostmot2/serial_link.hpp"

#include <algorithm>
#include <cmath>

namespace lbpkit::model::hm2 {

std::uint64_t SerialLink::nextRandom() {
  std::uint64_t z = (random_ += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

double SerialLink::uniform() { return static_cast<double>(nextRandom() >> 11) * 0x1.0p-53; }

std::uint64_t SerialLink::bitsToNextError(double rate) {
  if (rate <= 0) return UINT64_MAX;
  if (rate >= 1) return 0;
  // Inverse transform of the geometric distribution: one draw per error,
  // not one per bit, so a low rate costs nothing per character.
  const double u = 1.0 - uniform();  // (0, 1]
  const double k = std::floor(std::log(u) / std::log1p(-rate));
  return k >= 1.8e19 ? UINT64_MAX : static_cast<std::uint64_t>(k);
}

void SerialLink::setRates(const RateSettings& settings) {
  rates_ = settings;
  noRates_ = settings.breakRate <= 0 && settings.toRemote == Rates{} && settings.fromRemote == Rates{};
  random_ = settings.seed;
  toRemoteRate_.bitsToError = bitsToNextError(settings.toRemote.bitErrorRate);
  fromRemoteRate_.bitsToError = bitsToNextError(settings.fromRemote.bitErrorRate);
}

unsigned SerialLink::damage(Direction d, std::uint8_t& byte) {
  Faults& f = faults(d);
  if (f.drop > 0) {
    --f.drop;
    ++counters_.dropped;
    return 0;
  }
  if (f.corrupt > 0) {
    --f.corrupt;
    ++counters_.corrupted;
    byte ^= 0x5A;  // several bits flipped: the CRC catches it
  }
  const Rates& r = ratesOf(d);
  if (r.dropRate > 0 && uniform() < r.dropRate) {
    ++counters_.dropped;
    return 0;
  }
  if (r.bitErrorRate > 0) {
    RateState& st = rateState(d);
    bool hit = false;
    while (st.bitsToError < 8) {
      byte = static_cast<std::uint8_t>(byte ^ (1U << st.bitsToError));
      ++counters_.bitErrors;
      hit = true;
      const std::uint64_t next = bitsToNextError(r.bitErrorRate);
      st.bitsToError = next == UINT64_MAX ? UINT64_MAX : st.bitsToError + 1 + next;
    }
    if (st.bitsToError != UINT64_MAX) st.bitsToError -= 8;
    if (hit) ++counters_.corrupted;
  }
  return 1;
}

bool SerialLink::extraAfter(Direction d) {
  const double rate = ratesOf(d).extraRate;
  if (rate <= 0 || uniform() >= rate) return false;
  ++counters_.added;
  return true;
}

unsigned SerialLink::extras(Faults& f) {
  const unsigned n = f.add;
  counters_.added += n;
  f.add = 0;
  return n;
}

void SerialLink::consumeOutbox(std::size_t count) {
  count = std::min(count, outboxSize_);
  std::copy(outbox_.begin() + static_cast<std::ptrdiff_t>(count),
            outbox_.begin() + static_cast<std::ptrdiff_t>(outboxSize_), outbox_.begin());
  outboxSize_ -= count;
}

SerialLink::Reply SerialLink::exchange(std::span<const std::uint8_t> frame, SimTime start, std::uint32_t baud) {
  Reply reply;
  const SimTime ch = lbp::characterTime(baud);
  SimTime t = start;
  if (external_) {
    // The other process's reply comes later (Sslbp::remoteBytes); the
    // frame leaves now, through the same faults as to a model.
    auto post = [&](std::uint8_t b) {
      t += ch;
      ++counters_.toRemote;
      if (!connectedAt(t)) return;
      if (outboxSize_ < outbox_.size())
        outbox_[outboxSize_++] = b;
      else
        ++counters_.outboxOverflows;
    };
    for (std::uint8_t b : frame) {
      if (damage(Direction::ToRemote, b)) post(b);
      if (extraAfter(Direction::ToRemote)) post(static_cast<std::uint8_t>(nextRandom()));
    }
    for (unsigned k = extras(toRemote_); k > 0; --k) post(kNoise);
    reply.lastByteAt = t;
    return reply;
  }
  // A receiver only understands characters at its own baud rate: across a
  // mismatch (or a cut cable, or an unpowered remote) nothing comes back.
  const bool heard = connected_ && remote_ != nullptr && remote_->powered() && remote_->baud() == baud;
  if (heard && clean(start)) {
    // The frame's characters reach the remote one character time apart;
    // its reply comes back the same way after the turnaround. A process
    // data exchange (one special RPC) is handed over whole.
    auto take = [&](std::span<const std::uint8_t> bytes) {
      for (const auto x : bytes)
        if (reply.size < reply.bytes.size()) reply.bytes[reply.size++] = x;
    };
    if (const auto whole = remote_->receiveSpecialRpc(frame, t + ch, ch)) {
      t += ch * static_cast<SimTime::rep>(frame.size());
      take(*whole);
    } else {
      for (const std::uint8_t b : frame) {
        t += ch;
        take(remote_->receive(b, t));
      }
    }
    counters_.toRemote += frame.size();
    if (reply.size > 0) {
      t += kTurnaround + ch * static_cast<SimTime::rep>(reply.size);
      counters_.fromRemote += reply.size;
    }
    reply.lastByteAt = t;
    return reply;
  }
  std::array<std::uint8_t, kMaxReply> raw;  // the first rawSize are set
  std::size_t rawSize = 0;
  auto deliver = [&](std::uint8_t b) {
    t += ch;
    ++counters_.toRemote;
    if (!heard || !connectedAt(t)) return;
    for (auto x : remote_->receive(b, t))
      if (rawSize < raw.size()) raw[rawSize++] = x;
  };
  for (std::uint8_t b : frame) {
    if (damage(Direction::ToRemote, b)) deliver(b);
    if (extraAfter(Direction::ToRemote)) deliver(static_cast<std::uint8_t>(nextRandom()));
  }
  // Added characters: line noise right after the frame.
  for (unsigned k = extras(toRemote_); k > 0; --k) deliver(kNoise);
  reply.lastByteAt = t;
  if (rawSize == 0 && fromRemote_.add == 0) return reply;
  t += kTurnaround;
  auto arrive = [&](std::uint8_t b) {
    if (reply.size >= reply.bytes.size()) return;
    t += ch;
    ++counters_.fromRemote;
    if (!connectedAt(t)) return;  // the cable pulled mid-reply
    reply.bytes[reply.size++] = b;
  };
  for (std::size_t i = 0; i < rawSize; ++i) {
    std::uint8_t b = raw[i];
    if (damage(Direction::FromRemote, b)) arrive(b);
    if (extraAfter(Direction::FromRemote)) arrive(static_cast<std::uint8_t>(nextRandom()));
  }
  for (unsigned k = extras(fromRemote_); k > 0; --k) arrive(kNoise);
  const bool rateBreak = rates_.breakRate > 0 && reply.size > 0 && uniform() < rates_.breakRate;
  if ((breakNext_ || rateBreak) && reply.size > 0) {
    if (!rateBreak) breakNext_ = false;
    reply.breakSeen = true;
    ++counters_.breaks;
  }
  reply.lastByteAt = t;
  return reply;
}

}  // namespace lbpkit::model::hm2
