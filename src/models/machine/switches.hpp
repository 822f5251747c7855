// SPDX-License-Identifier: MIT
// The switches wired to the 7I77's field inputs (manual: FIELD
// INPUT/OUTPUT CONNECTORS, FIELD INPUT CHARACTERISTICS, WHY SINKING INPUTS),
// or to the 7I76's on the 7I77+7I76 firmwares: home and limit
// switches that trip at positions along an axis, the E-stop chain, a probe.
// A closed contact puts its board's field power on its input, an open one
// leaves it at 0 V. Limits and the E-stop chain are normally closed, so the
// input is on while all is well and a broken wire reads as tripped (the
// manual's reason for sinking inputs: a grounded input is never "active").
// The 7I76's inputs are taken to work as the 7I77's (seven_i76.hpp).
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "hostmot2/ioport.hpp"
#include <vector>

#include "machine/daughtercard.hpp"
#include "remote/field_io.hpp"
#include "remote/seven_i76.hpp"

namespace lbpkit::model::machine {

enum class SwitchKind { Home, MinLimit, MaxLimit, Estop, Probe, Other };
enum class Contact { NormallyOpen, NormallyClosed };

struct SwitchParameters {
  std::string name;  // "x-home", "estop", ...
  SwitchKind kind = SwitchKind::Other;
  unsigned input = 0;  // field input 0..31
  Contact contact = Contact::NormallyOpen;
  // An axis switch trips when the axis is at or past `position` (machine
  // units): at or above it with tripAbove, at or below it otherwise. A
  // switch on no axis trips only when told (setTripped).
  std::string axis;  // empty: on no axis
  double position = 0.0;
  bool tripAbove = true;
  Daughtercard daughtercard = Daughtercard::SevenI77;  // whose field input

  bool operator==(const SwitchParameters&) const = default;
};

// The field inputs switches can be wired to: the 7I77's, the 7I76's on the
// firmwares that have one (nullptr on the others), and the card's own IO
// pins (its IOPort: pin N is port N / width, bit N % width). A closed
// contact on a card pin drives it high, an open one low.
struct FieldInputs {
  remote::FieldIoProcessor* sevenI77 = nullptr;
  remote::SevenI76FieldIo* sevenI76 = nullptr;
  hm2::IoPort* card = nullptr;
};

class Switches {
 public:
  struct State {
    std::string name;
    SwitchKind kind = SwitchKind::Other;
    unsigned input = 0;
    bool tripped = false;  // the cam or the operator has it
    bool inputOn = false;  // what the input terminal gets: field power or not
    Daughtercard daughtercard = Daughtercard::SevenI77;
    bool operator==(const State&) const = default;
  };

  // `axisOf` gives each switch's axis index (-1: none), resolved by the machine.
  Switches(std::vector<SwitchParameters> switches, std::vector<int> axisOf);

  // Trip or release a switch by hand (E-stop button, probe touch, a
  // stuck switch); it stays so until released. False if no switch has that name.
  bool setTripped(const std::string& name, bool tripped);
  // Positions of every axis (machine units) -> input voltages at the field
  // I/O processors; only inputs whose state changed (or whose board's field
  // voltage did) are set again. Every switch's board must be in `io`
  // (std::invalid_argument otherwise: the machine checks it first).
  void apply(const double* axisPositions, const FieldInputs& io);

  [[nodiscard]] std::size_t size() const { return switches_.size(); }
  [[nodiscard]] const SwitchParameters& parameters(std::size_t i) const { return switches_.at(i); }
  [[nodiscard]] int axisOf(std::size_t i) const { return axisOf_.at(i); }
  [[nodiscard]] State state(std::size_t i) const;

 private:
  [[nodiscard]] bool on(std::size_t i) const;
  // The positions of an axis at which none of its switches changes state
  // from the last apply(): lo <= q <= hi (a switch that trips above p keeps
  // its state for q < p, i.e. q <= the double below p: exact at the trip points).
  struct Unchanged {
    double lo, hi;
  };
  [[nodiscard]] bool unchanged(const double* axisPositions) const;
  std::vector<SwitchParameters> switches_;
  std::vector<int> axisOf_;
  std::vector<std::uint8_t> tripped_;  // by position, from the last apply()
  std::vector<std::uint8_t> forced_;   // by hand
  std::vector<std::uint8_t> applied_;  // 0 off, 1 on, 2 never applied
  std::array<double, 3> appliedField_{-1.0, -1.0, -1.0};  // per Daughtercard
  // apply() runs at every plant span; it has nothing to do while no switch
  // is tripped or released by hand (dirty_), the field voltage is the same
  // and every axis stays where its switches keep their states.
  bool dirty_ = true;
  std::vector<int> axes_;               // the axes that carry switches
  std::vector<Unchanged> unchanged_;    // per axis index
};

}  // namespace lbpkit::model::machine
