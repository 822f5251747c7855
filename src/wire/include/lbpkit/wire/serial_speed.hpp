// SPDX-License-Identifier: MIT
// The baud rates a serial line to an LBP remote can be set to on Linux: the
// rates the 7I77's processors talk at in setup mode (115200) and operate
// mode (2.5 Mbaud by default; manual: SERIAL INTERFACE, and the SSLBP
// channel baud rate local), and the standard ones below. A USB or PCI
// serial adapter takes what its driver supports of these; a pty takes any.
#pragma once

#include <optional>

namespace lbpkit::wire {

// The termios speed (a speed_t for cfsetspeed) for `baud`; none for a rate
// termios cannot name.
[[nodiscard]] std::optional<unsigned> termiosSpeed(unsigned baud);

}  // namespace lbpkit::wire
