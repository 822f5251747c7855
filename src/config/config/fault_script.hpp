// SPDX-License-Identifier: MIT
// A fault script: `[[fault]]` entries in the sim's TOML
// (`lbpkit sim --config FILE`) or in a file of their own (`--script FILE`:
// examples/scenarios/), each a control-API request carried out at a
// set simulated time, and perhaps undone a while later, so that a user or a
// test replays the same bad day every run:
//
//   [[fault]]
//   at = "2.5s"            # simulated time since the sim started
//   fault = "network"      # POST /api/network ...
//   drop = 0.01            # ... with the entry's other keys as its body
//   for = "200ms"          # then as it was before (network, link, cable, overtemp)
//
// Read here (file, line and key in every error); carried out by the daemon
// with the API's own code, so a script can do nothing the API cannot.
#pragma once

#include <chrono>
#include <optional>
#include <string>
#include <vector>

namespace lbpkit::config {

struct ScriptedFault {
  std::chrono::nanoseconds at{0};
  std::string fault;  // the API's kind: network, cable, input, ...
  std::string body;   // the request body: the entry's other keys, as JSON text
  std::optional<std::chrono::nanoseconds> lasts;  // "for": undone after this long
  std::string where;  // "FILE:LINE:COL", for what the daemon says about it
};

// The kinds that end by themselves (`for`; the daemon knows how to undo
// them). The kinds a script may name are the API's POST routes but time.
inline constexpr const char* kUndoableFaultKinds[] = {"network", "link", "cable", "overtemp"};

// The `[[fault]]` entries of `path`, in time order (entries at the same time
// in file order). Throws FileError (config/toml_reader.hpp). `scriptOnly`:
// the file is a fault script of its own (`lbpkit sim --script`), so any key
// but `fault` at its top is an error, where a card's TOML has its card too.
std::vector<ScriptedFault> loadFaultScript(const std::string& path, bool scriptOnly = false);

// "2.5s", "200ms" or "150us" (a bare number is seconds), up to a day.
// Throws std::invalid_argument saying what a duration looks like.
std::chrono::nanoseconds parseDuration(const std::string& text);

}  // namespace lbpkit::config
