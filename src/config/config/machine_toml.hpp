// SPDX-License-Identifier: MIT
// Machine files: the machine behind the 7I77 and the 7I76 (model::machine::MachineDescription)
// written in TOML. examples/machines/mill.toml documents the schema, with
// units and defaults; mill.toml, lathe.toml and gantry.toml there load to
// exactly the built-ins model::machine::mill(), lathe() and gantry().
#pragma once

#include <string>

#include "machine/machine_file.hpp"

namespace lbpkit::config {

// "mill", "lathe" or "gantry": the built-in; anything else: a machine file.
// Throws FileError (config/toml_reader.hpp) "FILE:LINE:COL: key: what" for
// every mistake: unknown keys (with "did you mean"), wrong types, values out
// of range, and wiring the 7I77 (or the 7I76: `daughtercard = "7I76"`)
// cannot have or that contradicts itself (an input, output, analog output
// or encoder used twice on a board; a switch on an axis the machine lacks;
// a limit switch inside the travel or past the hard stop). Whether the
// card's firmware has a 7I76 is the machine's to check (model::machine::Machine,
// with MachineDescription::sevenI76Where to point at the key).
[[nodiscard]] model::machine::MachineDescription loadMachine(const std::string& nameOrPath);

// The machine file at `path` (no built-ins).
[[nodiscard]] model::machine::MachineDescription loadMachineFile(const std::string& path);

}  // namespace lbpkit::config
