// SPDX-License-Identifier: MIT
// Which folders `lbpkit linuxcnc --linuxcnc-root` enters
// (linuxcnc/linuxcnc_root.hpp): what runs as root follows no path a user
// could plant, so a root that is relative, reached through a link, under a
// folder others may write to, or without LinuxCNC is refused, each with
// the reason; and which of this PC's folders the root gives instead.
#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "linuxcnc/linuxcnc_root.hpp"
#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using lbpkit::linuxcnc::isSystemFolder;
using lbpkit::linuxcnc::linuxCncRootProblem;

bool says(const std::string& problem, const std::string& what) { return problem.find(what) != std::string::npos; }

TEST(LinuxCncRoot, ARelativePathOrAMissingFolderIsRefused) {
  EXPECT_TRUE(says(linuxCncRootProblem("var/cache/lbpkit/linuxcnc/trixie"), "not an absolute path"));
  EXPECT_TRUE(says(linuxCncRootProblem(""), "not an absolute path"));
  EXPECT_TRUE(says(linuxCncRootProblem("/nonexistent-lbpkit-root"), "No such file"));
}

TEST(LinuxCncRoot, AFolderOthersMayWriteOnTheWayIsRefused) {
  // Under /tmp (mode 1777): another user could have put it there.
  test_support::TempDir dir("lbpkit-root");
  fs::create_directories(dir.path() / "usr/bin");
  std::ofstream(dir.path() / "usr/bin/linuxcnc") << "#!/bin/sh\n";
  const auto problem = linuxCncRootProblem(dir.path().string());
  EXPECT_TRUE(says(problem, dir.path().string() + ": /tmp is not root's own, or another user may write to it"))
      << problem;
}

TEST(LinuxCncRoot, APathThroughALinkIsRefused) {
  if (!fs::exists("/bin") || !fs::is_symlink("/bin")) GTEST_SKIP() << "/bin is not a link on this PC";
  const auto problem = linuxCncRootProblem("/bin");
  EXPECT_TRUE(says(problem, "a path through a link")) << problem;
}

TEST(LinuxCncRoot, AFolderWithoutLinuxCncIsRefused) {
  // Root's own and writable by root alone, but no LinuxCNC in it.
  if (::geteuid() != 0) GTEST_SKIP() << "the check reads folders root owns; run as root";
  const auto problem = linuxCncRootProblem("/usr/share");
  EXPECT_TRUE(says(problem, "no /usr/bin/linuxcnc in it")) << problem;
}

TEST(LinuxCncRoot, TheRootGivesTheSystemFoldersAndThisPcTheRest) {
  for (const char* system : {"usr", "etc", "var", "opt", "bin", "sbin", "lib", "lib64"})
    EXPECT_TRUE(isSystemFolder(system)) << system;
  for (const char* own : {"home", "root", "tmp", "run", "dev", "proc", "sys", "work", "srv", "mnt", "media"})
    EXPECT_FALSE(isSystemFolder(own)) << own;
}

}  // namespace
