// SPDX-License-Identifier: MIT
// Files lbpkit carries compiled in (apps/lbpkit/embed_text.cmake writes their
// definitions at build time), so that it never looks for them beside the
// binary.
#pragma once

#include <string_view>

namespace lbpkit::app {

// apps/lbpkit/rehearse_driver.py: lbpkit rehearse writes it to a folder of
// root's for LinuxCNC to run as its display.
std::string_view rehearseDriverSource();

}  // namespace lbpkit::app
