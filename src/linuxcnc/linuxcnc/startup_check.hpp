// SPDX-License-Identifier: MIT
// LinuxCNC's start-up check of a configuration's INI, as lbpkit check-config
// repeats it: the script the `linuxcnc` command runs before it loads
// anything (LinuxCNC: lib/hallib/check_config.tcl, installed as
// /usr/share/linuxcnc/hallib/check_config.tcl), which refuses a
// configuration with no [KINS]KINEMATICS or [KINS]JOINTS and, for trivkins,
// a joint whose MIN_LIMIT/MAX_LIMIT do not hold those of the axis it moves,
// and warns of defaults it takes. docs/check-config.md#linuxcncs-start-up-checks
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "linuxcnc/hal_config.hpp"

namespace lbpkit::linuxcnc {

// The findings of LinuxCNC's start-up check on the INI `ini`, named
// `shownAs` (its file name, as other findings give it): an error for each
// thing that makes the check refuse the configuration, a warning for each it
// warns of. None when the INI's [EMC]VERSION is not 1.1: `linuxcnc` first
// converts such a file with update_ini, and checks the converted one.
std::vector<Finding> startupCheck(const std::filesystem::path& ini, const std::string& shownAs);

}  // namespace lbpkit::linuxcnc
