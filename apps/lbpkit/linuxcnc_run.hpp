// SPDX-License-Identifier: MIT
// What `sudo lbpkit linuxcnc` does as root, kept to sudo's rules
// (docs/linuxcnc.md#what-runs-as-root): the user it runs LinuxCNC as, the
// run's own folder, the names its namespace and link carry, what a dead run
// left, the addresses this PC already has, and the reaper that makes
// everything a run started end with it, even when it is killed outright.
#pragma once

#include <sys/stat.h>
#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "linuxcnc/board_address.hpp"

namespace lbpkit::app::linuxcnc_run {

// Who LinuxCNC runs as: the user who ran sudo (SUDO_UID, SUDO_GID,
// SUDO_USER, each checked against the account database), or root itself
// when root ran lbpkit (rtapi_app then drops to nobody: RTAPI_UID).
struct RunAs {
  bool root = true;
  uid_t uid = 0;
  gid_t gid = 0;
  std::string name = "root";
  std::string home = "/root";
  std::vector<gid_t> groups;  // the user's supplementary groups
};
// Throws lbpkit::Error naming the variable when SUDO_UID, SUDO_GID or
// SUDO_USER is set but does not name a real account, or they disagree.
RunAs invokingUser();
// In a child about to run something as `user`: its groups, group and user,
// for good (setgroups, setresgid, setresuid). False when the kernel refused.
bool dropTo(const RunAs& user);

// A run's names carry the pid of the `lbpkit linuxcnc` that owns them:
// network namespace lbpkit-linuxcnc-PID, link lblPID (LinuxCNC's end:
// lblPIDh), folder /tmp/lbpkit-linuxcnc-PID-XXXXXX.
std::string namespaceName(pid_t owner);
std::string linkName(pid_t owner);

// The run's folder: made by mkdtemp (never one that was there), root's,
// mode 0711 so that LinuxCNC's user may reach what is named inside but
// nobody else may add to it. Every file in it is made through its
// descriptor (openat with O_EXCL|O_NOFOLLOW) and every mode set through a
// descriptor. Removed, without following a link, when destroyed.
class RunFolder {
 public:
  explicit RunFolder(pid_t owner);
  ~RunFolder();
  RunFolder(const RunFolder&) = delete;
  RunFolder& operator=(const RunFolder&) = delete;
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  // A new folder `name` inside, `mode`, belonging to `owner` (its user and
  // group): its path.
  std::filesystem::path makeFolder(const std::string& name, mode_t mode, const RunAs& owner);
  // A new file `name` inside, root's, mode 0644, holding `text`: its path.
  std::filesystem::path writeFile(const std::string& name, const std::string& text);

 private:
  std::filesystem::path path_;
  int fd_ = -1;
};

// Removes folder `path` and everything in it without following a link:
// each level is opened with O_NOFOLLOW and emptied through its descriptor.
void removeTree(const std::filesystem::path& path);

// Whether an `lbpkit linuxcnc` with this pid still runs.
bool runIsAlive(pid_t owner);
// Removes what runs that are no longer alive left behind (a namespace, a
// link, a folder, by the names above), saying what it removed.
void removeDeadRuns();
// Removes the folders of the run with this pid (root's own folders by the
// name above, never one that another user made): their paths.
std::vector<std::string> removeRunFolders(pid_t owner);

// Why the card may not have `board` on this PC: it is an address of one of
// its interfaces (another run's card, naming that run), the gateway of one
// of its routes, or already routed to a link by a /32; nullopt when free.
std::optional<std::string> hostAddressProblem(lbpkit::linuxcnc::Ipv4 board);
// LinuxCNC's address beside the card: the first in the card's /24 from .2
// up that is neither the card's nor an address, a gateway or a /32 route of
// this PC's; nullopt when there is none.
std::optional<lbpkit::linuxcnc::Ipv4> peerFor(lbpkit::linuxcnc::Ipv4 board);

// Starts the run's reaper: the first process of a new PID namespace (PID 1
// there), which waits
// for this process (`owner`) to end however it ends (a pipe only this
// process holds). Then it kills every process of the namespace (whatever
// the run started, and whatever that started), removes the run's network
// namespace `netns`, link `link` and folders (removeRunFolders), and ends.
// Call it before making anything else of the run.
void startReaper(pid_t owner, const std::string& netns, const std::string& link);
// The reaper's pipe (write end), which a child that does not exec at once
// closes: -1 before startReaper.
int reaperPipe();
// fork(), the child in the run's PID namespace (after startReaper), without
// the reaper's pipe. Every process the run starts that is not waited for
// at once is started this way.
pid_t forkInRun();

// A file of `owner`'s, opened by root without trusting its path: with
// O_NOFOLLOW|O_NONBLOCK, and kept only if it is a regular file that belongs
// to `owner` (`st` says what it is). Its descriptor, or -1.
int openUsersFile(const std::filesystem::path& path, uid_t owner, struct stat& st);
// Such a file, read whole if it was written at or after `notBefore`: at
// most `limit` bytes (the last `limit` otherwise).
std::optional<std::string> readUsersFile(const std::filesystem::path& path, uid_t owner,
                                         std::chrono::system_clock::time_point notBefore, std::size_t limit);

}  // namespace lbpkit::app::linuxcnc_run
