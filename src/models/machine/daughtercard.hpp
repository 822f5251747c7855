// Which daughtercard's terminals a part of the machine is wired to (issue
// 17): the 7I77 (its field inputs and outputs, analog outputs, drive
// enables and encoders), or the 7I76 that sits beside it on the 7I77+7I76
// firmwares (its field inputs and outputs, its spindle interface SpinOut,
// SpinEna and SpinDir, and its spindle encoder; docs/cards.md#the-7i76-field-io).
#pragma once

#include <cstdint>
#include <string_view>

namespace machine {

enum class Daughtercard : std::uint8_t { SevenI77, SevenI76 };

// "7I77", "7I76": as Mesa names them.
[[nodiscard]] constexpr std::string_view daughtercardName(Daughtercard d) {
  return d == Daughtercard::SevenI76 ? "7I76" : "7I77";
}

}  // namespace machine
