// SPDX-License-Identifier: MIT
// What the steps of lbpkit machine --from-config share as they derive a
// machine from a LinuxCNC configuration: the configuration (its INI and HAL
// files), its HAL signal graph, the findings said so far, the machine built
// so far, and the values read from it (a setp of a hostmot2 parameter, else
// the INI's [SECTION]KEY, as LinuxCNC's sample configurations write them)
// with the bounds each must keep to.
#pragma once

#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "linuxcnc/derive_common.hpp"
#include "linuxcnc/hal_config.hpp"
#include "linuxcnc/hal_graph.hpp"
#include "linuxcnc/machine_toml_writer.hpp"

namespace lbpkit::linuxcnc::detail {

struct DeriveContext {
  DeriveContext(const HalConfig& hal, std::vector<Finding>& findings, const std::filesystem::path& ini);

  const HalConfig& hal;
  std::filesystem::path ini;
  Diagnostics diag;
  HalGraph graph;
  MachineOut out;
  bool inch = false;      // [TRAJ]LINEAR_UNITS inch
  bool sevenI76 = false;  // a 7I76 is netted (its spindle encoder is counter 6)
  // Joints' pins: "joint" (LinuxCNC 2.8 and later), "axis" (2.7).
  std::string jointPinsName = "joint";
  Holds holds;  // the inputs' states at rest, so far
  // Each joint's own: one joint to each output, encoder and StepGen.
  std::set<unsigned> claimedStepgens, claimedEncoders, claimedAnalogs;

  void error(const Where& w, const std::string& name, const std::string& reason) { diag.error(w, name, reason); }
  void warning(const Where& w, const std::string& name, const std::string& reason) { diag.warning(w, name, reason); }
  [[nodiscard]] Where where(const std::string& pin) const { return graph.where(pin); }

  // Whether a value (none: nothing to check) is within `b`; an error naming
  // where it is written when not.
  bool within(const std::optional<Value>& v, const Bound& b);
  // A position (a limit, HOME_OFFSET) within kMaxPositionMm of 0; a rotary
  // joint's beyond it is taken as there, with a warning.
  bool position(std::optional<Value>& v, double mmPerUnit, bool angular);
  // A derived value within [low, high] of a machine file, else an error at
  // `v` (the INI key or setp it mostly comes from) saying what it gives.
  bool derived(double x, double low, double high, const Value& v, const std::string& what);
  // An encoder's lines and gearing on the assumed screw within a machine
  // file's.
  bool encoderFits(const Lines& e, const Value& scale);

  // A value from a setp of `halName`, else from the INI's [section]key.
  [[nodiscard]] std::optional<Value> value(const std::string& halName, const std::string& section,
                                           const std::string& key) const;
  // A value from the last setp of `halName` (a number), else none.
  [[nodiscard]] std::optional<Value> setpValue(const std::string& halName) const;
  [[nodiscard]] std::optional<Value> iniValue(const std::string& section, const std::string& key) const;
  // Where [SECTION] is: the line above its first key in the INI; for a
  // section whose keys all come from a file the INI includes, its [SECTION]
  // line.
  [[nodiscard]] Where sectionWhere(const std::string& section) const;

  // The switches placed so far as inputs' states at rest: a NC contact
  // reads on, a NO one off, until it trips.
  void seedHolds();
};

// " (through A, B)" for the components on an input's way, or "".
std::string via(const std::string& through);

// Every 7I77, 7I76, encoder, StepGen and card pin the nets name exists on
// the card: a number past the terminals is a pin LinuxCNC refuses. A field
// input, output or analog output off the first 7I77 is left out, with a
// warning.
void checkPins(DeriveContext& c);

}  // namespace lbpkit::linuxcnc::detail
