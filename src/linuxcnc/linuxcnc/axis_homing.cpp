// SPDX-License-Identifier: MIT
// A joint's travel, homing, switches and brake (axis_homing.hpp; the
// LinuxCNC INI documentation's homing section; the 7I77 manual's field
// inputs, read as on when a contact closes to field power).
#include "linuxcnc/axis_homing.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace lbpkit::linuxcnc::detail {

bool placeHoming(DeriveContext& c, const Joint& j, AxisOut& a, Homing& h) {
  const double lead = j.pitch / j.gear;
  const double leadUnits = lead / j.mmPerUnit;
  double lo = j.minLimit->v, hi = j.maxLimit->v;
  std::string homeComment;
  double initial = (lo + hi) / 2;
  std::optional<double> edge;
  const double latchDir = j.lv < 0 ? -1.0 : 1.0;
  if (j.sv == 0.0 && j.lv == 0.0) {
    initial = j.offset.v;
    homeComment = fmt::format("homes in place (HOME_SEARCH_VEL and HOME_LATCH_VEL 0): it starts at HOME_OFFSET ({})",
                              j.offset.from);
  } else if (j.sv == 0.0) {
    initial = j.useIndex ? j.offset.v - latchDir * leadUnits / 2 : j.offset.v;
    homeComment = fmt::format(
        "homes on the next index (HOME_SEARCH_VEL 0): it starts half a motor turn before "
        "HOME_OFFSET ({})",
        j.offset.from);
  } else {
    // The edge the latch finds; with the index, half a motor turn before
    // the index LinuxCNC calls HOME_OFFSET (the index comes at every whole
    // motor turn of the machine's position).
    edge = j.useIndex ? j.offset.v - latchDir * leadUnits / 2 : j.offset.v;
    homeComment = fmt::format("home switch edge where HOME_OFFSET ({}) falls{}", j.offset.from,
                              j.useIndex ? ", on the next index (HOME_USE_INDEX) half a motor turn on" : "");
    if (j.useIndex && std::abs(j.offset.v / leadUnits - std::round(j.offset.v / leadUnits)) > 1e-6)
      homeComment += fmt::format(
          " (HOME_OFFSET is no whole number of motor turns: LinuxCNC's coordinates are the "
          "machine's shifted by up to {} {})",
          fmtNumber(leadUnits), j.unitName);
    lo = std::min(lo, *edge);
    hi = std::max(hi, *edge);
    // Powered up two seconds' search from its home switch (at least 5
    // mm), within the travel: where the machine is at power-up is the one
    // thing no configuration says, and a search that long runs homing's
    // every phase (search, back-off, latch) as a longer one would.
    const double away = std::min(std::max(5.0 / j.mmPerUnit, 2.0 * std::abs(j.sv)), 0.4 * (hi - lo));
    initial = std::clamp(*edge - (j.sv > 0 ? away : -away), lo, hi);
    if (j.useIndex) {
      // The encoder's index comes at whole motor turns from where the
      // machine powered up (QuadratureEncoder): it starts a whole number
      // of turns from the index LinuxCNC calls HOME_OFFSET, so that the
      // index the latch finds half a turn past the edge is that one.
      const double side = initial < j.offset.v ? -1.0 : 1.0;
      const double turns = std::ceil(std::abs(j.offset.v - initial) / leadUnits - 1e-9);
      initial = j.offset.v + side * turns * leadUnits;
      if (initial < lo || initial > hi) initial = j.offset.v + side * (turns - 1) * leadUnits;
    }
    const double start = std::abs(*edge - initial);
    homeComment += fmt::format("; it starts {} {} from the switch, {} s of HOME_SEARCH_VEL", fmtNumber(start),
                               j.unitName, fmtNumber(start / std::abs(j.sv)));
  }
  const double stopDistance = j.sv * j.sv / (2 * j.amax);
  const double marginLow = 2.0 / j.mmPerUnit + leadUnits + (j.sv < 0 ? stopDistance : 0.0);
  const double marginHigh = 2.0 / j.mmPerUnit + leadUnits + (j.sv > 0 ? stopDistance : 0.0);
  const double stopAtSpeed = j.vmax * j.vmax / (2 * j.amax);
  const double overtravel =
      std::max(marginLow, marginHigh) * j.mmPerUnit + std::max(3.0, stopAtSpeed * j.mmPerUnit + 1.0);
  if (!c.derived(overtravel, 0.0, kMaxOvertravel,
                 j.maxAcc && j.maxAcc->v > 0 ? *j.maxAcc
                 : j.maxVel                  ? *j.maxVel
                                             : j.searchVel.value_or(j.offset),
                 "stopping from MAX_VELOCITY or HOME_SEARCH_VEL, hard stops (mm) past the travel at"))
    return false;
  a.keys.emplace_back("travel", fmt::format("[{}, {}]|{} to {}", fmtNumber(lo * j.mmPerUnit),
                                            fmtNumber(hi * j.mmPerUnit), j.minLimit->from, j.maxLimit->from));
  a.keys.emplace_back("overtravel", fmtNumber(std::ceil(overtravel)) +
                                        "|hard stops past the limit switches, and past a stop from MAX_VELOCITY");
  a.keys.emplace_back("initial_position",
                      fmtNumber(initial * j.mmPerUnit) + "|" +
                          (j.sv == 0.0 ? homeComment
                                       : fmt::format("{} {} from its home switch, on the side "
                                                     "HOME_SEARCH_VEL searches from",
                                                     fmtNumber(std::abs(*edge - initial)), j.unitName)));
  h = {lo, hi, initial, edge, homeComment, marginLow, marginHigh};
  return true;
}

void placeSwitches(DeriveContext& c, const Joint& j, const Homing& h) {
  const double lo = h.lo, hi = h.hi, marginLow = h.marginLow, marginHigh = h.marginHigh;
  const auto& edge = h.edge;
  const auto& homeComment = h.homeComment;
  // Which inputs the joint's switches are on.
  struct Role {
    std::string pin;
    const char* kind;
  };
  for (const Role& r :
       {Role{"home-sw-in", "home"}, Role{"neg-lim-sw-in", "min_limit"}, Role{"pos-lim-sw-in", "max_limit"}}) {
    std::vector<Source> sources;
    c.graph.trace(j.jp + r.pin, false, sources);
    for (const auto& s : sources) {
      const auto key = fmt::format("{}:{}", s.field.daughtercard, s.field.number);
      auto& sw = c.out.switchAt[key];
      const std::string kind = r.kind;
      if (kind == "home" && j.sv == 0.0) {
        if (sw.kind.empty()) c.out.homeInPlaceInputs.insert(key);
        continue;
      }
      if (!sw.kind.empty()) {
        if (sw.axis == j.name && sw.kind == "home") {
          sw.comment += fmt::format("; also {}{} ({})", j.jp, r.pin, at(c.where(j.jp + r.pin)));
        } else {
          c.warning(c.where(j.jp + r.pin), j.jp + r.pin,
                    fmt::format("{} input {} also serves {}{}: a machine file has one switch per input, so {} has "
                                "none of its own",
                                s.field.daughtercard, s.field.number, j.jp, r.pin, j.jp + r.pin));
        }
        continue;
      }
      sw.name = fmt::format("{}-{}", j.name, kind == "home" ? "home" : kind == "min_limit" ? "min" : "max");
      sw.kind = kind;
      sw.daughtercard = s.field.daughtercard;
      sw.input = s.field.number;
      sw.contact = s.inverted ? "nc" : "no";
      sw.axis = j.name;
      sw.pin = s.pin;
      if (kind == "home") {
        sw.position = *edge * j.mmPerUnit;
        sw.tripAbove = j.sv > 0;
        sw.comment = fmt::format("{} ({}), {} the edge: HOME_SEARCH_VEL {} searches {}; {}", s.pin, at(c.where(s.pin)),
                                 j.sv > 0 ? "closed at and above" : "closed at and below", fmtNumber(j.sv),
                                 j.sv > 0 ? "up" : "down", homeComment);
      } else if (kind == "min_limit") {
        sw.position = (lo - marginLow) * j.mmPerUnit;
        sw.tripAbove = false;
        sw.comment = fmt::format("{} ({}), past the travel by 2 mm, a motor turn and the homing search's stop", s.pin,
                                 at(c.where(s.pin)));
      } else {
        sw.position = (hi + marginHigh) * j.mmPerUnit;
        sw.tripAbove = true;
        sw.comment = fmt::format("{} ({}), past the travel by 2 mm, a motor turn and the homing search's stop", s.pin,
                                 at(c.where(s.pin)));
      }
      sw.comment += s.inverted ? "; NC: the net takes the inverted input" : "; NO: the net takes the input as it is";
      c.out.switchOrder.push_back(key);
    }
  }
}

void checkHomeSwitch(DeriveContext& c, const Joint& j) {
  if (j.sv != 0.0) {
    std::vector<Source> homes;
    c.graph.trace(j.jp + "home-sw-in", false, homes);
    if (homes.empty())
      c.error(j.iniAt, j.section,
              fmt::format("joint {}: HOME_SEARCH_VEL is {} but {}home-sw-in reaches no 7I77, 7I76 or card input ({}): "
                          "there is no home switch to place",
                          j.n, fmtNumber(j.sv), j.jp, c.graph.describe(j.jp + "home-sw-in")));
  }
}

void findBrake(DeriveContext& c, const Joint& j, AxisOut& a) {
  // A brake on this joint: an output whose signal its amp-enable writes
  // and whose name says brake.
  for (const auto& [sig, pins] : c.hal.signals) {
    if (lower(sig).find("brake") == std::string::npos || lower(sig).find("spindle") != std::string::npos) continue;
    const bool ours = std::find(pins.begin(), pins.end(), j.jp + "amp-enable-out") != pins.end() ||
                      lower(sig).find(j.name) != std::string::npos;
    if (!ours) continue;
    for (const auto& p : pins)
      if (const auto o = fieldPin(p, "output")) {
        a.brakeOutput = static_cast<int>(o->number);
        a.brakeDaughtercard = o->daughtercard;
        a.brakeComment = fmt::format("{} ({}) on signal {}: on releases it", p, at(c.where(p)), sig);
      }
  }
}

}  // namespace lbpkit::linuxcnc::detail
