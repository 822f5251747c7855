// SPDX-License-Identifier: MIT
// Running another program as root without a shell: `lbpkit linuxcnc`,
// `lbpkit bench` and the namespaces they build start `ip`, `update_ini` and
// LinuxCNC by an argument vector (posix_spawn), so that nothing a
// configuration holds (an address, a file name) is ever read as a command,
// and find them only in the system's own folders, never through a PATH a
// user could have set (docs/linuxcnc.md#what-runs-as-root).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lbpkit::linuxcnc {

// The system folders a program is looked for in, in this order.
inline constexpr std::string_view kSystemFolders[] = {"/usr/local/sbin", "/usr/local/bin", "/usr/sbin",
                                                      "/usr/bin",        "/sbin",           "/bin"};

// `name`'s absolute path in kSystemFolders (a regular, executable file), or
// nothing.
[[nodiscard]] std::optional<std::string> systemProgram(std::string_view name);

struct ProgramResult {
  int status = -1;     // the exit status; -1 when it could not start or was killed
  std::string output;  // what it wrote to stdout and stderr, together
};

// Runs argv (argv[0] a name looked up with systemProgram, or an absolute
// path) with stdin from /dev/null and its output collected, and waits for
// it. Never throws: a program that cannot start has status -1 and says why
// in `output`.
ProgramResult runProgram(const std::vector<std::string>& argv);

}  // namespace lbpkit::linuxcnc
