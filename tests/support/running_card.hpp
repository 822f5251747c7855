// SPDX-License-Identifier: MIT
// Test helper: the in-process virtual card with its 7I77 discovered and
// started in normal mode, ready for cycles.
#pragma once

#include "sim_card/sim_transport.hpp"
#include "lbpkit/sserial.hpp"

namespace testing_host {

inline lbpkit::SmartSerial::Options channels(std::uint8_t mask) {
  lbpkit::SmartSerial::Options o;
  o.channelMask = mask;
  return o;
}

struct RunningCard {
  lbpkit::SimTransport t;
  lbpkit::CardInfo info;
  lbpkit::SmartSerial ss;

  explicit RunningCard(lbpkit::model::hm2::HostMot2Card::Options card = {}, std::uint8_t mask = 0x03)
      : t(std::move(card)), info(lbpkit::readCardInfo(t)), ss(t, info, channels(mask)) {
    ss.discover(mask);
    ss.startNormal();
  }
};

}  // namespace testing_host
