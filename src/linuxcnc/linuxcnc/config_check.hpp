// SPDX-License-Identifier: MIT
// lbpkit check-config: reads a LinuxCNC configuration (an INI and the HAL
// files it names, or one HAL file) the way halcmd would, and reports every
// reference to a hostmot2 pin or parameter that LinuxCNC would refuse or
// that cannot work: no such name, a smart-serial channel with no remote or
// left out, a pin that exists only in another mode, a read-only parameter,
// two outputs on one signal, an input nothing writes; what LinuxCNC's
// start-up check refuses in the INI (startup_check.hpp); and a servo joint
// its 7I77 analog output's maxlim/minlim hold under its MAX_VELOCITY (a
// warning). Needs no LinuxCNC.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "linuxcnc/hal_config.hpp"
#include "linuxcnc/hm2_pins.hpp"

namespace lbpkit::linuxcnc {

// A board a configuration loads: its driver line and what it creates.
struct Board {
  std::string prefix;  // "hm2_7i92.0"
  std::string driver;  // "hm2_eth", "hm2_pci"
  std::string config;  // the config= string
  std::string boardIp;  // hm2_eth's board_ip= (the first board's), as written
  std::string file;
  unsigned line = 0;
  std::string model;        // "7I92T (7I77+7I76 firmware)"
  std::string description;  // the model, then its remotes: "..., 7I77 on channel 0 (mode 0), ..."
  // The firmware's module instances by HAL name (moduleInstances()).
  std::map<std::string, unsigned> modules;
  std::vector<Item> items;
  // What hostmot2 refuses in the config= string for this card (reported at
  // the driver's line): "num_stepgens=6, but the firmware has 5 StepGens".
  std::vector<std::string> loadProblems;
  // How many cards and firmwares the board could be (the checker keeps the
  // one under which the configuration has the fewest errors).
  std::size_t candidates = 1;
  // The same board's items with every channel in each other mode (for "wrong
  // mode" reasons): mode digit -> items.
  std::map<char, std::vector<Item>> itemsInMode;
};

// What the checker asks its caller: what the board `loaded.prefix`
// ("hm2_7i92.0") loaded by `loaded.driver` with `config`, carrying
// `sevenI77s` 7I77s (1 or 2) where its firmware can, may be: one Board per
// card and firmware of that LinuxCNC name (copies of `loaded` with the
// items, description and load problems filled in), in the order to prefer
// on a tie. None when lbpkit does not know that board (`whyNot` says why).
using BoardModel =
    std::function<std::vector<Board>(const Board& loaded, const Hm2Config& config, unsigned sevenI77s, std::string& whyNot)>;

struct CheckResult {
  std::vector<Finding> findings;
  std::vector<Board> boards;
  unsigned references = 0;  // hostmot2 names looked up
  std::vector<std::string> files;  // the HAL files read
  HalConfig hal;                    // the configuration as read: its INI, its HAL files' setp and nets
  [[nodiscard]] bool ok() const;
};

CheckResult checkConfig(const std::filesystem::path& file, const BoardModel& model);

}  // namespace lbpkit::linuxcnc
