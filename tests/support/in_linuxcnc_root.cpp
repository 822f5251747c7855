// SPDX-License-Identifier: MIT
// lbpkit_in_linuxcnc_root ROOT COMMAND [ARGUMENT...]: COMMAND run from
// another Debian release's LinuxCNC root (lbpkit_linuxcnc's
// enterLinuxCncRoot, what `lbpkit linuxcnc --linuxcnc-root` does), in a
// mount namespace of its own that ends with it. The real-client tests put
// it in front of halcmd, mesaflash and linuxcnc when LBPKIT_LINUXCNC_ROOT
// names a release (support/interop.hpp, docs/testing.md).
#include <sched.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <string>

#include "linuxcnc/linuxcnc_root.hpp"

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s ROOT COMMAND [ARGUMENT...]\n", argv[0]);
    return 2;
  }
  if (::unshare(CLONE_NEWNS) != 0) {
    std::fprintf(stderr, "%s: a mount namespace of its own: %s\n", argv[0], std::strerror(errno));
    return 126;
  }
  if (const auto problem = lbpkit::linuxcnc::enterLinuxCncRoot(argv[1]); !problem.empty()) {
    std::fprintf(stderr, "%s: %s\n", argv[0], problem.c_str());
    return 126;
  }
  ::execvp(argv[2], argv + 2);
  std::fprintf(stderr, "%s: %s in %s: %s\n", argv[0], argv[2], argv[1], std::strerror(errno));
  return 127;
}
