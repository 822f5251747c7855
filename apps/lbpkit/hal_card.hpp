// SPDX-License-Identifier: MIT
// What `lbpkit pins` and `lbpkit check-config` share: a card's HAL items as
// LinuxCNC's hostmot2 would create them, from the card's IDROM and the
// discovery of its smart-serial remotes in the configured modes.
#pragma once

#include <string>
#include <vector>

#include "linuxcnc/hm2_pins.hpp"
#include "hostmot2/cards/catalogue.hpp"
#include "lbpkit/transport.hpp"

namespace lbpkit::app {

// Discovers the remotes on every smart-serial port the configuration uses,
// each channel in its configured mode ('x' channels are left alone).
std::vector<lbpkit::linuxcnc::Remote> discoverRemotes(lbpkit::Transport& t, const lbpkit::CardInfo& card,
                                                 const lbpkit::linuxcnc::Hm2Config& config);

// An in-process virtual card of the catalogue (docs/cards.md) with one of
// its firmwares and `sevenI77s` 7I77s (2 only where the firmware has a
// second 7I77 connector): its IDROM, its remotes, no network (check-config's
// model of a machine, `lbpkit pins` without --addr).
struct VirtualCard {
  lbpkit::CardInfo info;
  std::vector<lbpkit::linuxcnc::Remote> remotes;
  std::string halName;  // hm2_eth's name for it: "7i92"
};
VirtualCard virtualCard(const lbpkit::model::hm2::cards::Card& card,
                        const lbpkit::model::hm2::cards::Firmware& firmware, unsigned sevenI77s,
                        const lbpkit::linuxcnc::Hm2Config& config);

// --card NAME and --pinout NAME as given (either may be empty): the card
// (the default when no name) and its firmware (the card's default when no
// name). Throws lbpkit::Error naming the cards or firmwares there are.
std::pair<const lbpkit::model::hm2::cards::Card*, const lbpkit::model::hm2::cards::Firmware*> catalogueChoice(
    const std::string& card, const std::string& pinout);

}  // namespace lbpkit::app
