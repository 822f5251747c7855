// SPDX-License-Identifier: MIT
// The card configuration of `lbpkit sim --config FILE` (docs/sim.md: `--config`;
// examples/sim.toml): which daughtercards, field voltage, 7I77 or 7I77D,
// jumpers, unit numbers.
#pragma once

#include <string>

#include "hostmot2/card.hpp"

namespace lbpkit::config {

// Reads `path` into `card`, keeping the EEPROM file names already set in
// card.first (the second connector's get the same with ".2"). Throws
// FileError (config/toml_reader.hpp) naming file, line, column and key.
void loadConfig(const std::string& path, model::hm2::HostMot2Card::Options& card);

}  // namespace lbpkit::config
