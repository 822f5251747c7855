// What `lbpkit pins` and `lbpkit check-config` share: a card's HAL items as
// LinuxCNC's hostmot2 would create them, from the card's IDROM and the
// discovery of its smart-serial remotes in the configured modes.
#pragma once

#include <string>
#include <vector>

#include "hal/hm2_pins.hpp"
#include "lbpkit/transport.hpp"

namespace app {

// Discovers the remotes on every smart-serial port the configuration uses,
// each channel in its configured mode ('x' channels are left alone).
std::vector<lbpkit::hal::Remote> discoverRemotes(lbpkit::Transport& t, const lbpkit::CardInfo& card,
                                                 const lbpkit::hal::Hm2Config& config);

// The in-process virtual 7I92 with `sevenI77s` (1 or 2) 7I77s: its IDROM and
// remotes, no network (check-config's model of a 7I92 or 7I76E machine).
struct VirtualCard {
  lbpkit::CardInfo info;
  std::vector<lbpkit::hal::Remote> remotes;
};
VirtualCard virtualCard(unsigned sevenI77s, const lbpkit::hal::Hm2Config& config);

}  // namespace app
