// SPDX-License-Identifier: MIT
// The machine lbpkit machine --from-config derives, as it is written out: its
// axes (servo drives on 7I77 analog outputs, steppers on StepGens), switches
// on field inputs, spindle and field outputs, each value with the INI key
// or HAL line it came from; and the machine file's text
// (examples/machines/mill.toml is the schema).
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "linuxcnc/hal_config.hpp"

namespace lbpkit::linuxcnc::detail {

// A machine file line's value and its comment: "value|why" ("why" may be
// empty).
using KeyValues = std::vector<std::pair<std::string, std::string>>;

// A [[switch]]: one field input's switch ("held-off": an input that must
// read off, so none).
struct SwitchOut {
  std::string name, kind, daughtercard, contact, axis, comment;
  unsigned input = 0;
  std::optional<double> position;
  bool tripAbove = true;
  std::string pin;  // the field pin it is on, as netted
};

// An [[output]]: a field output some net drives.
struct OutputOut {
  std::string name, daughtercard, comment;
  unsigned output = 0;
};

// An [[axis]] and its [axis.stepper] or [[axis.drive]] table.
struct AxisOut {
  std::string name, comment;
  KeyValues keys;         // key = value, comment
  std::string tableName;  // "axis.drive" or "axis.stepper"
  KeyValues drive;
  KeyValues amplifier;
  int brakeOutput = -1;
  std::string brakeDaughtercard, brakeComment;
};

// Everything derived, in the order it is written.
struct MachineOut {
  std::vector<AxisOut> axes;
  std::map<std::string, SwitchOut> switchAt;  // "7I77:3" -> the switch on that input
  std::vector<std::string> switchOrder;       // the inputs as their switches were placed
  std::vector<std::string> heldOff;           // comments: inputs that must read off
  std::set<std::string> homeInPlaceInputs;    // home switches no joint searches for
  KeyValues spindle;
  std::vector<OutputOut> outputs;
};

// The machine file for `m`, derived from the INI `ini` and the files `hal`
// read.
std::string machineToml(const MachineOut& m, const HalConfig& hal, const std::filesystem::path& ini);

}  // namespace lbpkit::linuxcnc::detail
