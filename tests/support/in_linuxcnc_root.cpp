// SPDX-License-Identifier: MIT
// lbpkit_in_linuxcnc_root [--tmp DIR] ROOT COMMAND [ARGUMENT...]: COMMAND
// run from another Debian release's LinuxCNC root (lbpkit_linuxcnc's
// enterLinuxCncRoot, what `lbpkit linuxcnc --linuxcnc-root` does), in a
// mount namespace of its own that ends with it; with --tmp, DIR is its /tmp
// (a LinuxCNC of the test's own, as `lbpkit linuxcnc` gives it one: bound
// here, since a root may have no mount program). The real-client tests put
// it in front of halcmd, mesaflash and linuxcnc when LBPKIT_LINUXCNC_ROOT
// names a release (support/linuxcnc_release.hpp, docs/testing.md).
#include <sched.h>
#include <sys/mount.h>
#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <string>

#include "linuxcnc/linuxcnc_root.hpp"

int main(int argc, char** argv) {
  int first = 1;
  const char* tmp = nullptr;
  if (argc > 2 && std::strcmp(argv[1], "--tmp") == 0) {
    tmp = argv[2];
    first = 3;
  }
  if (argc < first + 2) {
    std::fprintf(stderr, "usage: %s [--tmp DIR] ROOT COMMAND [ARGUMENT...]\n", argv[0]);
    return 2;
  }
  const char* root = argv[first];
  if (::unshare(CLONE_NEWNS) != 0 || ::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0) {
    std::fprintf(stderr, "%s: a mount namespace of its own: %s\n", argv[0], std::strerror(errno));
    return 126;
  }
  if (tmp != nullptr && ::mount(tmp, "/tmp", nullptr, MS_BIND, nullptr) != 0) {
    std::fprintf(stderr, "%s: %s as /tmp: %s\n", argv[0], tmp, std::strerror(errno));
    return 126;
  }
  if (const auto problem = lbpkit::linuxcnc::enterLinuxCncRoot(root); !problem.empty()) {
    std::fprintf(stderr, "%s: %s\n", argv[0], problem.c_str());
    return 126;
  }
  ::execvp(argv[first + 1], argv + first + 1);
  std::fprintf(stderr, "%s: %s in %s: %s\n", argv[0], argv[first + 1], root, std::strerror(errno));
  return 127;
}
