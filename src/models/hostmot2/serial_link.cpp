#include "hostmot2/serial_link.hpp"

#include <algorithm>

namespace hm2 {

unsigned SerialLink::damage(Faults& f, std::uint8_t& byte) {
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
  return 1;
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
    // The other process's reply comes later (SmartSerial::remoteBytes); the
    // frame leaves now, through the same faults as to a model.
    auto post = [&](std::uint8_t b) {
      t += ch;
      ++counters_.toRemote;
      if (!connected_) return;
      if (outboxSize_ < outbox_.size())
        outbox_[outboxSize_++] = b;
      else
        ++counters_.outboxOverflows;
    };
    for (std::uint8_t b : frame)
      if (damage(toRemote_, b)) post(b);
    for (unsigned k = extras(toRemote_); k > 0; --k) post(kNoise);
    reply.lastByteAt = t;
    return reply;
  }
  // A receiver only understands characters at its own baud rate: across a
  // mismatch (or a cut cable, or an unpowered remote) nothing comes back.
  const bool heard = connected_ && remote_ != nullptr && remote_->powered() && remote_->baud() == baud;
  std::array<std::uint8_t, kMaxReply> raw;  // the first rawSize are set
  std::size_t rawSize = 0;
  auto deliver = [&](std::uint8_t b) {
    t += ch;
    ++counters_.toRemote;
    if (!heard) return;
    for (auto x : remote_->receive(b, t))
      if (rawSize < raw.size()) raw[rawSize++] = x;
  };
  for (std::uint8_t b : frame)
    if (damage(toRemote_, b)) deliver(b);
  // Added characters: line noise right after the frame.
  for (unsigned k = extras(toRemote_); k > 0; --k) deliver(kNoise);
  reply.lastByteAt = t;
  if (rawSize == 0 && fromRemote_.add == 0) return reply;
  t += kTurnaround;
  auto arrive = [&](std::uint8_t b) {
    if (reply.size >= reply.bytes.size()) return;
    t += ch;
    ++counters_.fromRemote;
    reply.bytes[reply.size++] = b;
  };
  for (std::size_t i = 0; i < rawSize; ++i) {
    std::uint8_t b = raw[i];
    if (damage(fromRemote_, b)) arrive(b);
  }
  for (unsigned k = extras(fromRemote_); k > 0; --k) arrive(kNoise);
  if (breakNext_ && reply.size > 0) {
    breakNext_ = false;
    reply.breakSeen = true;
    ++counters_.breaks;
  }
  reply.lastByteAt = t;
  return reply;
}

}  // namespace hm2
