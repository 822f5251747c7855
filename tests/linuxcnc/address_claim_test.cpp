// SPDX-License-Identifier: MIT
// The claim `lbpkit linuxcnc` holds while it chooses the card's and
// LinuxCNC's addresses and makes their link and routes
// (linuxcnc/network_namespace.hpp): one run at a time, so that two runs
// started at once never choose the same free address; and, since it runs
// as root, a lock file that is a link or another user's is refused by name.
#include <fcntl.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cerrno>
#include <filesystem>
#include <fstream>
#include <string>

#include "lbpkit/error.hpp"
#include "linuxcnc/network_namespace.hpp"
#include "support/temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using lbpkit::linuxcnc::AddressClaim;

// Whether another process could take the lock on `file` now.
bool lockable(const fs::path& file) {
  const int fd = ::open(file.c_str(), O_RDWR | O_CLOEXEC);
  if (fd < 0) return false;
  const bool taken = ::flock(fd, LOCK_EX | LOCK_NB) == 0;
  ::close(fd);
  return taken;
}

TEST(AddressClaim, IsHeldByOneRunAtATimeUntilItEnds) {
  if (::geteuid() != 0) GTEST_SKIP() << "the claim is root's";
  test_support::TempDir dir("lbpkit-claim");
  const auto file = dir.path() / "claim.lock";
  int held[2], done[2];
  ASSERT_EQ(::pipe(held), 0);
  ASSERT_EQ(::pipe(done), 0);
  const pid_t run = ::fork();
  ASSERT_GE(run, 0);
  if (run == 0) {
    // Another run: it claims, says so, and holds the claim until told.
    AddressClaim claim(file.string());
    char c = 'h';
    (void)!::write(held[1], &c, 1);
    (void)!::read(done[0], &c, 1);
    ::_exit(0);
  }
  char c = 0;
  ASSERT_EQ(::read(held[0], &c, 1), 1);
  EXPECT_FALSE(lockable(file)) << "a second run could choose while the first holds the claim";
  ASSERT_EQ(::write(done[1], &c, 1), 1);
  int status = 0;
  ASSERT_EQ(::waitpid(run, &status, 0), run);
  EXPECT_TRUE(lockable(file)) << "the claim outlived its run";
  {
    AddressClaim mine(file.string());
    EXPECT_FALSE(lockable(file));
  }
  EXPECT_TRUE(lockable(file));
  for (int fd : {held[0], held[1], done[0], done[1]}) ::close(fd);
}

TEST(AddressClaim, ALockFileThatIsALinkOrAnotherUsersIsRefusedByName) {
  if (::geteuid() != 0) GTEST_SKIP() << "the claim is root's";
  test_support::TempDir dir("lbpkit-claim");
  const auto target = dir.path() / "target";
  std::ofstream(target).close();
  const auto link = dir.path() / "claim.lock";
  fs::create_symlink(target, link);
  try {
    AddressClaim claim(link.string());
    ADD_FAILURE() << "a link was followed";
  } catch (const lbpkit::Error& e) {
    EXPECT_NE(std::string(e.what()).find(link.string()), std::string::npos) << e.what();
  }
  const auto planted = dir.path() / "planted.lock";
  std::ofstream(planted).close();
  ASSERT_EQ(::chown(planted.c_str(), 65534, 65534), 0);
  try {
    AddressClaim claim(planted.string());
    ADD_FAILURE() << "another user's file was locked";
  } catch (const lbpkit::Error& e) {
    EXPECT_NE(std::string(e.what()).find(planted.string() + " is not a file of root's"), std::string::npos) << e.what();
  }
}

}  // namespace
