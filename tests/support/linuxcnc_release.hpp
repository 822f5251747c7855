// SPDX-License-Identifier: MIT
// Which LinuxCNC the real-client tests run: this PC's (Debian 12's
// linuxcnc-uspace and mesaflash), or, when LBPKIT_LINUXCNC_ROOT names one,
// another Debian release's from a root scripts/linuxcnc-releases made
// (Debian 13's 2.9.4, Debian unstable's 2.9.9). tests/CMakeLists.txt
// registers the real-client tests once more for each release with the
// variable set; the programs then run through lbpkit_in_linuxcnc_root
// (support/in_linuxcnc_root.cpp), the sim and the test stay on this PC.
#pragma once

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "process/process.hpp"

namespace test_support {

// The release's root, or "" for this PC's LinuxCNC.
inline std::string linuxCncRoot() {
  const char* root = std::getenv("LBPKIT_LINUXCNC_ROOT");
  return root != nullptr ? root : "";
}

// What goes in front of a LinuxCNC or mesaflash program (after `ip netns
// exec NS`, before `env`): the release's root entered, or nothing.
inline std::string inLinuxCncRoot() {
  const auto root = linuxCncRoot();
  return root.empty() ? std::string() : std::string(LBPKIT_IN_LINUXCNC_ROOT) + " " + root + " ";
}

// The same as an argument vector's first words.
inline std::vector<std::string> inLinuxCncRootArgs() {
  const auto root = linuxCncRoot();
  if (root.empty()) return {};
  return {LBPKIT_IN_LINUXCNC_ROOT, root};
}

// A Debian package's version in the release's root (or this PC), from dpkg's
// status file: "1:2.9.4-2+deb13u1"; "" when it is not installed.
inline std::string packageVersion(const std::string& package) {
  std::ifstream status(linuxCncRoot() + "/var/lib/dpkg/status");
  bool in = false;
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("Package: ", 0) == 0) in = line.substr(9) == package;
    else if (in && line.rfind("Version: ", 0) == 0) return line.substr(9);
  }
  return "";
}

// A package's release as major, minor, patch (LinuxCNC 2.9.0 for Debian
// 12's 2.9.0~pre1 snapshot, mesaflash 3.4.6 or 3.4.9): what a per-release
// expectation compares.
struct Release {
  int major = 0, minor = 0, patch = 0;
  [[nodiscard]] bool atLeast(int ma, int mi, int pa) const {
    return major != ma ? major > ma : minor != mi ? minor > mi : patch >= pa;
  }
};
inline Release releaseOf(const std::string& package) {
  auto v = packageVersion(package);
  if (const auto colon = v.find(':'); colon != std::string::npos) v = v.substr(colon + 1);
  Release r;
  std::sscanf(v.c_str(), "%d.%d.%d", &r.major, &r.minor, &r.patch);
  return r;
}
inline Release linuxCncRelease() { return releaseOf("linuxcnc-uspace"); }

// A LinuxCNC or mesaflash program is installed where the tests run it. A
// release's root that lacks it is a failure, not a skip: the test was asked
// for that release.
inline bool haveClientProgram(const std::string& name) {
  const auto root = linuxCncRoot();
  if (lbpkit::process::systemProgram(name, root)) return true;
  // Fatal, so that the test's body does not run after its fixture skips.
  if (!root.empty())
    [&] { FAIL() << "LBPKIT_LINUXCNC_ROOT=" << root << " has no " << name
                 << " (scripts/linuxcnc-releases makes the releases' roots)"; }();
  return false;
}

}  // namespace test_support
