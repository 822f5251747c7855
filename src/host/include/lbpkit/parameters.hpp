// SPDX-License-Identifier: MIT
// Parameters by name, like Mesa's RPD and WPD (manual: RPD, WPD, AND
// UFLBP): read and write any GTOC or PTOC element of a remote, the
// non-volatile ones through the remote's EEPROM access (local 0xEC = 1, the
// way LinuxCNC and mesaflash do it).
#pragma once

#include <cstdint>
#include <string>

#include "lbpkit/discovery.hpp"

namespace lbpkit {

std::uint64_t readElement(RemoteAccess& remote, const ProcessDataElement& e);
// Throws lbpkit::Error when the remote refused the write (LBP Invalid write
// status) or, for a non-volatile element, when its EEPROM does not read back
// the value written: a value only counts as saved when the remote kept it.
void writeElement(RemoteAccess& remote, const ProcessDataElement& e, std::uint64_t raw);

// RPD's output: decimal, or hexadecimal with `hex` ("H" on the command line).
std::string formatElement(const ProcessDataElement& e, std::uint64_t raw, bool hex);
// WPD's input: a number in decimal (or with a 0x prefix), or hex with `hex`.
// Throws lbpkit::Error when it is not a number or does not fit the element.
std::uint64_t parseElement(const ProcessDataElement& e, const std::string& text, bool hex);

}  // namespace lbpkit
