// SPDX-License-Identifier: MIT
// The processes of one network namespace, as /proc shows them: what `lbpkit
// linuxcnc` looks for in the LinuxCNC it started (its rtapi_app, the error
// window of its linuxcnc script), and nothing of another LinuxCNC on the PC.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <functional>
#include <string>

namespace lbpkit::linuxcnc {

// The inode of /proc/PID/ns/net: 0 when the process is gone.
unsigned long networkNamespaceOf(const std::filesystem::path& proc);
// /proc/PID/comm (or a thread's /proc/PID/task/TID/comm): the name it gave
// itself, at most 15 characters.
std::string commandOf(const std::filesystem::path& proc);
// Calls `f` with /proc/PID of each process in `networkNamespace`.
void forEachProcessIn(unsigned long networkNamespace, const std::function<void(const std::filesystem::path&)>& f);

// The linuxcnc script, started without a terminal but with a desktop, shows
// what LinuxCNC printed in a window of its own when it ends with an error
// (its ErrorCheck: wish running LinuxCNC's show_errors.tcl) and waits there
// until the user closes it. True while such a window is open in
// `networkNamespace`.
bool errorWindowIsOpen(unsigned long networkNamespace);

}  // namespace lbpkit::linuxcnc
