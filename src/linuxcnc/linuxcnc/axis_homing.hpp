// SPDX-License-Identifier: MIT
// A joint's travel, homing and switches (the LinuxCNC INI documentation's
// homing section: HOME_SEARCH_VEL, HOME_LATCH_VEL, HOME_USE_INDEX,
// HOME_OFFSET; MIN_LIMIT and MAX_LIMIT): where the machine powers up, where
// its home switch's edge falls, and the limit switches past the travel, on
// the field inputs the HAL files net to the joint's home-sw-in,
// neg-lim-sw-in and pos-lim-sw-in; and a brake on a field output.
#pragma once

#include <optional>
#include <string>

#include "linuxcnc/axis_deriver.hpp"
#include "linuxcnc/derive_context.hpp"

namespace lbpkit::linuxcnc::detail {

// Where a joint's homing puts things, in its own units.
struct Homing {
  double lo = 0.0, hi = 0.0;   // the travel, the home switch's edge included
  double initial = 0.0;        // where it powers up
  std::optional<double> edge;  // the home switch's edge (none: it homes in place)
  std::string homeComment;
  double marginLow = 0.0, marginHigh = 0.0;  // the limit switches past the travel
};

// The axis's travel, overtravel and initial position; false (an error
// said) when its hard stops would be past a machine file's.
bool placeHoming(DeriveContext& c, const Joint& j, AxisOut& a, Homing& h);
// Its home and limit switches, on the inputs that reach home-sw-in,
// neg-lim-sw-in and pos-lim-sw-in.
void placeSwitches(DeriveContext& c, const Joint& j, const Homing& h);
// An error when it searches for a home switch that no input reaches.
void checkHomeSwitch(DeriveContext& c, const Joint& j);
// A brake on this joint: an output whose signal its amp-enable writes and
// whose name says brake.
void findBrake(DeriveContext& c, const Joint& j, AxisOut& a);

}  // namespace lbpkit::linuxcnc::detail
