#include "hostmot2/serial_link.hpp"

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

SerialLink::Reply SerialLink::exchange(std::span<const std::uint8_t> frame, SimTime start, std::uint32_t baud) {
  Reply reply;
  const SimTime ch = lbp::characterTime(baud);
  SimTime t = start;
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
