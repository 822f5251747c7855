// SPDX-License-Identifier: MIT
// Other programs and this one's CPUs, for everything of lbpkit's that starts
// a program or places a thread: the apps (`lbpkit linuxcnc`, `lbpkit
// bench`), the sim's card thread and the tests' support. Programs are found
// in the system's own folders, never through a PATH a user set, and started
// by an argument vector, never a shell (docs/linuxcnc.md#what-runs-as-root).
// Depends on nothing of lbpkit's (its own layer: scripts/check-layers).
#pragma once

#include <sys/types.h>

#include <chrono>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lbpkit::process {

// The system folders a program is looked for in, in this order.
inline constexpr std::string_view kSystemFolders[] = {"/usr/local/sbin", "/usr/local/bin", "/usr/sbin",
                                                      "/usr/bin",        "/sbin",           "/bin"};

// `name`'s absolute path in kSystemFolders (a regular, executable file),
// or nothing; under `root` (another system's root, such as a LinuxCNC
// release's: the path is then the one inside it) when given.
[[nodiscard]] std::optional<std::string> systemProgram(std::string_view name, const std::string& root = {});

struct ProgramResult {
  int status = -1;     // the exit status; -1 when it could not start or was killed
  std::string output;  // what it wrote to stdout and stderr, together
};

// Runs argv (argv[0] a name looked up with systemProgram, or an absolute
// path) with stdin from /dev/null and its output collected, and waits for
// it. Never throws: a program that cannot start has status -1 and says why
// in `output`.
ProgramResult runProgram(const std::vector<std::string>& argv);

// How spawn() starts a child.
struct SpawnOptions {
  int out = -1;     // its stdout and stderr (a descriptor of ours), or inherited (-1)
  int err = -2;     // its stderr alone, when not -2 (then `out` is stdout only)
  int ready = -1;   // a descriptor it gets as its 3 (a program's --ready-fd 3), or none
  std::optional<unsigned> cpu;  // it, and what it starts, on this CPU alone
  bool ownProcessGroup = false;  // a terminal's Ctrl-C reaches only us, who stop it in order
  int deathSignal = 0;           // sent to it when we die (PR_SET_PDEATHSIG), 0: none
  bool nullStdin = true;         // stdin from /dev/null
  pid_t (*fork)() = nullptr;     // how to fork (into a PID namespace of the caller's), else fork()
};

// Forks and execs argv[0] (an absolute path) with argv: the child's pid.
// Throws std::runtime_error when it cannot fork; a program that cannot be
// executed exits 127.
pid_t spawn(const std::vector<std::string>& argv, const SpawnOptions& options = {});

// Waits for `pid` (retrying on EINTR): its wait status.
int reap(pid_t pid);

// Stops a child as a user would: SIGTERM (or `signal`), then SIGKILL (to
// its whole process group too with `group`) when it has not ended within
// `grace`; reaps it. Its exit status, 128 + the signal that ended it, or -1
// when there was no child; *killed says whether it took the SIGKILL.
int stopWithGrace(pid_t pid, std::chrono::milliseconds grace, int signal = 15, bool group = false,
                  bool* killed = nullptr);

// The CPUs this process may run on (its affinity: taskset, a container's
// cpuset), ascending.
[[nodiscard]] std::vector<unsigned> allowedCpus();

// This process (and what it starts afterwards) on `cpu` alone; false when
// the kernel refused.
bool pinToCpu(unsigned cpu);

// A --cpu option's value: a CPU's number, `last` (the last this process may
// use) or `any` (not pinned: nothing). Throws std::invalid_argument naming
// `option` when the text is none of these or names a CPU this process may
// not use.
[[nodiscard]] std::optional<unsigned> parseCpu(const std::string& text, std::string_view option = "--cpu");

}  // namespace lbpkit::process
