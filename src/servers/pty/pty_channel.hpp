// SPDX-License-Identifier: MIT
// An SSLBP channel of the virtual card brought out to a pseudo-terminal, for
// a remote of the user's own (`lbpkit sim --remote 2=pty`): the TB6
// expansion port, channel 2, with a smart-serial remote in development on
// the other end (manual: SSLBP; LBP). The channel's frames go out on the
// pty; what comes back is the remote's reply, judged by SSLBP as a reply on
// the cable would be, with the reply timeouts relaxed
// (Sslbp::kExternalTimeoutFactor).
//
// pump() never blocks and allocates nothing: the daemon's card thread calls
// it between datagrams. Frames nobody reads wait in the pty (a few kB), then
// in the link's outbox, then are lost (counted in the link's counters).
#pragma once

#include <cstdint>
#include <string>

#include "hostmot2/card.hpp"
#include "pty/pty_pair.hpp"

namespace lbpkit::server {

class PtyChannel {
 public:
  // Makes `channel`'s link external. Throws std::invalid_argument for a
  // channel the card does not have, or one a 7I77 processor is on.
  PtyChannel(model::hm2::HostMot2Card& card, unsigned channel);

  [[nodiscard]] unsigned channel() const { return channel_; }
  // The slave side, what the remote's program opens.
  [[nodiscard]] const std::string& path() const { return pty_.path(); }
  // The channel's baud rate when the pty was made (its termios speed).
  [[nodiscard]] std::uint32_t baud() const { return baud_; }

  // Moves the channel's outgoing frames to the pty and the remote's bytes
  // to SSLBP, at simulated time `now` (the card's).
  void pump(model::hm2::HostMot2Card& card, model::lbp::SimTime now);

  [[nodiscard]] std::uint64_t bytesToRemote() const { return toRemote_; }
  [[nodiscard]] std::uint64_t bytesFromRemote() const { return fromRemote_; }

 private:
  unsigned channel_;
  std::uint32_t baud_;
  PtyPair pty_;
  std::uint64_t toRemote_ = 0;
  std::uint64_t fromRemote_ = 0;
};

}  // namespace lbpkit::server
