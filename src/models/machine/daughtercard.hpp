// SPDX-License-Identifier: MIT
// Which terminals a part of the machine is wired to: the 7I77's (its field
// inputs and outputs, analog outputs, drive enables and encoders), the
// 7I76's that sits beside it on the 7I77+7I76 firmwares (its field inputs
// and outputs, its spindle interface SpinOut, SpinEna and SpinDir, and its
// spindle encoder; docs/cards.md#the-7i76-field-io), or, for a switch, an IO
// pin of the FPGA card itself (LinuxCNC's gpio.NNN: the 7I96S's TB3 inputs).
#pragma once

#include <cstdint>
#include <string_view>

namespace lbpkit::model::machine {

enum class Daughtercard : std::uint8_t { SevenI77, SevenI76, Card };

// "7I77", "7I76": as Mesa names them; "card": the FPGA card's own pins.
[[nodiscard]] constexpr std::string_view daughtercardName(Daughtercard d) {
  return d == Daughtercard::SevenI76 ? "7I76" : d == Daughtercard::Card ? "card" : "7I77";
}

}  // namespace lbpkit::model::machine
