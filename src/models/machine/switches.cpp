// SPDX-License-Identifier: MIT
#include "machine/switches.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace lbpkit::model::machine {

Switches::Switches(std::vector<SwitchParameters> switches, std::vector<int> axisOf)
    : switches_(std::move(switches)), axisOf_(std::move(axisOf)) {
  if (axisOf_.size() != switches_.size()) throw std::invalid_argument("switches: one axis index per switch");
  for (const auto& s : switches_) {
    if (s.daughtercard == Daughtercard::Card) continue;  // the card's pins: the machine checks them
    const unsigned inputs = s.daughtercard == Daughtercard::SevenI76 ? remote::SevenI76FieldIo::kInputs
                                                                     : remote::FieldIoProcessor::kInputs;
    if (s.input >= inputs)
      throw std::invalid_argument("switch " + s.name + ": field input " + std::to_string(s.input) + " is not on the " +
                                  std::string(daughtercardName(s.daughtercard)) + " (0.." +
                                  std::to_string(inputs - 1) + ")");
  }
  tripped_.assign(switches_.size(), 0);
  forced_.assign(switches_.size(), 0);
  applied_.assign(switches_.size(), 2);
  for (const int a : axisOf_) {
    if (a < 0) continue;
    if (std::find(axes_.begin(), axes_.end(), a) == axes_.end()) axes_.push_back(a);
    if (static_cast<std::size_t>(a) >= unchanged_.size()) unchanged_.resize(static_cast<std::size_t>(a) + 1);
  }
}

bool Switches::setTripped(const std::string& name, bool tripped) {
  bool found = false;
  for (std::size_t i = 0; i < switches_.size(); ++i)
    if (switches_[i].name == name) {
      forced_[i] = tripped;
      found = true;
      dirty_ = true;
    }
  return found;
}

bool Switches::on(std::size_t i) const {
  // A closed contact gives the input field power: a tripped normally-open
  // switch closes, a tripped normally-closed one opens.
  const bool tripped = tripped_[i] || forced_[i];
  return tripped != (switches_[i].contact == Contact::NormallyClosed);
}

bool Switches::unchanged(const double* axisPositions) const {
  for (const int a : axes_) {
    const double q = axisPositions[a];
    const Unchanged& u = unchanged_[static_cast<std::size_t>(a)];
    if (!(q >= u.lo && q <= u.hi)) return false;
  }
  return true;
}

void Switches::apply(const double* axisPositions, const FieldInputs& io) {
  // Each board's field power: what a closed contact puts on its inputs.
  // (The card's own pins have no field power of their own: 1, on.)
  const std::array<double, 3> field{io.sevenI77 != nullptr ? io.sevenI77->fieldVoltage() : 0.0,
                                    io.sevenI76 != nullptr ? io.sevenI76->fieldVoltage() : 0.0, 1.0};
  const std::array<bool, 3> fieldChanged{field[0] != appliedField_[0], field[1] != appliedField_[1],
                                         field[2] != appliedField_[2]};
  // Every input already shows what it would be set to: nothing to do.
  if (!fieldChanged[0] && !fieldChanged[1] && !fieldChanged[2] && !dirty_ && unchanged(axisPositions)) return;
  appliedField_ = field;
  dirty_ = false;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  for (const int a : axes_) unchanged_[static_cast<std::size_t>(a)] = {-kInf, kInf};
  for (std::size_t i = 0; i < switches_.size(); ++i) {
    if (const int a = axisOf_[i]; a >= 0) {
      const double pos = axisPositions[a];
      const auto& s = switches_[i];
      tripped_[i] = s.tripAbove ? pos >= s.position : pos <= s.position;
      // Where this switch keeps its state.
      Unchanged& u = unchanged_[static_cast<std::size_t>(a)];
      if (s.tripAbove && tripped_[i]) u.lo = std::max(u.lo, s.position);                         // q >= p
      if (s.tripAbove && !tripped_[i]) u.hi = std::min(u.hi, std::nextafter(s.position, -kInf));  // q < p
      if (!s.tripAbove && tripped_[i]) u.hi = std::min(u.hi, s.position);                         // q <= p
      if (!s.tripAbove && !tripped_[i]) u.lo = std::max(u.lo, std::nextafter(s.position, kInf));  // q > p
      if (std::isnan(pos)) u = {kInf, -kInf};  // no position is safe: look again next time
    }
    const auto board = static_cast<std::size_t>(switches_[i].daughtercard);
    const std::uint8_t now = on(i) ? 1 : 0;
    if (now == applied_[i] && !fieldChanged[board]) continue;
    applied_[i] = now;
    const double volts = now ? field[board] : 0.0;
    if (switches_[i].daughtercard == Daughtercard::Card) {
      if (io.card == nullptr) throw std::invalid_argument("switch " + switches_[i].name + ": the card has no IO pins");
      const unsigned width = io.card->width();
      io.card->setInput(switches_[i].input / width, switches_[i].input % width, now != 0);
    } else if (switches_[i].daughtercard == Daughtercard::SevenI76) {
      if (io.sevenI76 == nullptr) throw std::invalid_argument("switch " + switches_[i].name + ": no 7I76 to wire it to");
      io.sevenI76->setInputVoltage(switches_[i].input, volts);
    } else {
      if (io.sevenI77 == nullptr) throw std::invalid_argument("switch " + switches_[i].name + ": no 7I77 to wire it to");
      io.sevenI77->setInputVoltage(switches_[i].input, volts);
    }
  }
}

Switches::State Switches::state(std::size_t i) const {
  const auto& s = switches_.at(i);
  return State{s.name, s.kind, s.input, tripped_[i] || forced_[i], on(i), s.daughtercard};
}

}  // namespace lbpkit::model::machine
