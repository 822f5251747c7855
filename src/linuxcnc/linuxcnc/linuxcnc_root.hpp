// SPDX-License-Identifier: MIT
// Another Debian release's LinuxCNC on this PC: a folder that holds a whole
// Debian root with linuxcnc-uspace installed (scripts/linuxcnc-releases
// makes them with mmdebstrap: Debian 13's 2.9.4, Debian unstable's 2.9.9),
// entered as containers enter an image. The root gives the system's own
// folders (/usr, /etc, /var, /opt and the /bin, /lib links into /usr);
// every other folder of this PC's root (/home, /root, /tmp, /run, /dev,
// /proc, /sys and the user's own, /work or /srv) is bound in as it is, so
// that a configuration, a display program, HAL's fifo and the X server's
// socket are where they were. Used by `lbpkit linuxcnc --linuxcnc-root`
// and by the tests that run each release against the sim
// (docs/linuxcnc.md#other-linuxcnc-releases).
#pragma once

#include <string>

namespace lbpkit::linuxcnc {

// Why `root` cannot be entered as a LinuxCNC root, or "" when it can: an
// absolute path without links, each folder on it root's own and writable
// by root alone (what runs as root follows no path a user could plant),
// holding /usr/bin/linuxcnc.
[[nodiscard]] std::string linuxCncRootProblem(const std::string& root);

// The folders of this PC's root that the LinuxCNC root gives instead.
[[nodiscard]] bool isSystemFolder(const std::string& name);

// Makes this process's mount namespace private (call it in a namespace of
// its own: unshare(CLONE_NEWNS)), binds this PC's folders into `root` (the
// system ones excepted) and enters it (chroot), keeping the working folder
// where it exists. "" when it did, else what failed.
[[nodiscard]] std::string enterLinuxCncRoot(const std::string& root);

}  // namespace lbpkit::linuxcnc
