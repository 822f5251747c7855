// SPDX-License-Identifier: MIT
#include "pty/pty_channel.hpp"

#include <unistd.h>

#include <array>
#include <stdexcept>
#include <string>

namespace lbpkit::server {

namespace {

// Refuses what cannot be an external remote's channel, before any pty is made.
unsigned checked(model::hm2::HostMot2Card& card, unsigned channel) {
  auto& sserial = card.part<model::hm2::Sslbp>();
  if (channel >= sserial.channels())
    throw std::invalid_argument("channel " + std::to_string(channel) + " does not exist: the card has channels 0.." +
                                std::to_string(sserial.channels() - 1));
  if (const auto* device = sserial.link(channel).remote(); device != nullptr)
    throw std::invalid_argument(
        "channel " + std::to_string(channel) + " carries the 7I77's " +
        (dynamic_cast<const model::remote::FieldIoProcessor*>(device) != nullptr ? "field I/O" : "analog") +
        " processor");
  return channel;
}

}  // namespace

PtyChannel::PtyChannel(model::hm2::HostMot2Card& card, unsigned channel)
    : channel_(checked(card, channel)), baud_(card.part<model::hm2::Sslbp>().channelBaud(channel)), pty_(baud_) {
  card.part<model::hm2::Sslbp>().link(channel_).setExternal(true);
}

void PtyChannel::pump(model::hm2::HostMot2Card& card, model::lbp::SimTime now) {
  auto& sserial = card.part<model::hm2::Sslbp>();
  card.advance(now);
  // The remote's bytes first: a reply judged now frees the channel for its
  // next frame, which then goes out below.
  std::array<std::uint8_t, 256> in;
  for (;;) {
    const ssize_t n = ::read(pty_.master(), in.data(), in.size());
    if (n <= 0) break;  // EAGAIN: nothing more
    fromRemote_ += static_cast<std::uint64_t>(n);
    sserial.remoteBytes(channel_, {in.data(), static_cast<std::size_t>(n)}, now);
  }
  auto& link = sserial.link(channel_);
  const auto out = link.outbox();
  if (out.empty()) return;
  const ssize_t w = ::write(pty_.master(), out.data(), out.size());
  if (w <= 0) return;  // the pty is full: the outbox keeps them
  toRemote_ += static_cast<std::uint64_t>(w);
  link.consumeOutbox(static_cast<std::size_t>(w));
}

}  // namespace lbpkit::server
