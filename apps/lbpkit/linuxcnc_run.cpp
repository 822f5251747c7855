// SPDX-License-Identifier: MIT
#include "linuxcnc_run.hpp"

#include <arpa/inet.h>
#include <dirent.h>
#include <fcntl.h>
#include <grp.h>
#include <ifaddrs.h>
#include <net/route.h>
#include <netinet/in.h>
#include <poll.h>
#include <pwd.h>
#include <sched.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/core.h>

#include <bit>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "lbpkit/error.hpp"
#include "process/process.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace app = lbpkit::app;

namespace lbpkit::app::linuxcnc_run {

namespace fs = std::filesystem;
using lbpkit::linuxcnc::Ipv4;

namespace {

// A whole decimal number, nothing else, that fits `T`.
template <typename T>
std::optional<T> wholeNumber(const char* text) {
  if (text == nullptr || *text == '\0' || std::strlen(text) > 10) return std::nullopt;
  unsigned long long n = 0;
  for (const char* c = text; *c != '\0'; ++c) {
    if (*c < '0' || *c > '9') return std::nullopt;
    n = n * 10 + static_cast<unsigned>(*c - '0');
  }
  if (n > static_cast<unsigned long long>(static_cast<T>(-1))) return std::nullopt;
  return static_cast<T>(n);
}

std::string firstLine(const fs::path& p) {
  std::ifstream in(p);
  std::string line;
  std::getline(in, line);
  return line;
}

int gReaperPipe = -1;
int gOwnPidNamespace = -1;  // this process's PID namespace
int gRunPidNamespace = -1;  // the run's, whose PID 1 is the reaper

}  // namespace

RunAs invokingUser() {
  RunAs who;
  const char* uidText = std::getenv("SUDO_UID");
  const char* gidText = std::getenv("SUDO_GID");
  const char* userText = std::getenv("SUDO_USER");
  // Root's own LinuxCNC keeps root's HOME (where it writes its logs).
  if (const char* home = std::getenv("HOME"); home != nullptr && home[0] == '/') who.home = home;
  if (uidText == nullptr && gidText == nullptr && userText == nullptr) return who;
  const auto uid = wholeNumber<uid_t>(uidText);
  if (!uid)
    throw lbpkit::Error(fmt::format("SUDO_UID={:?} is not a user's number: lbpkit linuxcnc runs LinuxCNC as the user "
                                    "who ran sudo and will not guess who that is",
                                    uidText == nullptr ? "" : uidText));
  const passwd* pw = ::getpwuid(*uid);
  if (pw == nullptr)
    throw lbpkit::Error(fmt::format("SUDO_UID={} names no account on this PC: lbpkit linuxcnc runs LinuxCNC as the "
                                    "user who ran sudo",
                                    *uid));
  const auto gid = wholeNumber<gid_t>(gidText);
  if (!gid || ::getgrgid(*gid) == nullptr)
    throw lbpkit::Error(fmt::format("SUDO_GID={:?} names no group on this PC", gidText == nullptr ? "" : gidText));
  if (userText != nullptr && pw->pw_name != nullptr && std::string(userText) != pw->pw_name)
    throw lbpkit::Error(fmt::format("SUDO_USER={:?} is not the account SUDO_UID={} names ({})", userText, *uid,
                                    pw->pw_name));
  if (*uid == 0) return who;  // root ran sudo
  who.root = false;
  who.uid = *uid;
  who.gid = *gid;
  who.name = pw->pw_name;
  who.home = pw->pw_dir != nullptr && pw->pw_dir[0] == '/' ? pw->pw_dir : "/";
  int n = 64;
  std::vector<gid_t> groups(static_cast<std::size_t>(n));
  if (::getgrouplist(pw->pw_name, *gid, groups.data(), &n) < 0) {
    groups.resize(static_cast<std::size_t>(n));
    ::getgrouplist(pw->pw_name, *gid, groups.data(), &n);
  }
  groups.resize(static_cast<std::size_t>(std::max(n, 0)));
  who.groups = groups;
  return who;
}

bool dropTo(const RunAs& user) {
  if (user.root) return true;
  if (::setgroups(user.groups.size(), user.groups.data()) != 0) return false;
  if (::setresgid(user.gid, user.gid, user.gid) != 0) return false;
  if (::setresuid(user.uid, user.uid, user.uid) != 0) return false;
  return ::geteuid() == user.uid && ::getegid() == user.gid;
}

std::string namespaceName(pid_t owner) { return fmt::format("lbpkit-linuxcnc-{}", owner); }
std::string linkName(pid_t owner) { return fmt::format("lbl{}", owner); }

RunFolder::RunFolder(pid_t owner) {
  std::string name = fmt::format("/tmp/lbpkit-linuxcnc-{}-XXXXXX", owner);
  if (::mkdtemp(name.data()) == nullptr)
    throw lbpkit::Error(fmt::format("cannot make the run's folder in /tmp: {}", std::strerror(errno)));
  path_ = name;
  fd_ = ::open(name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd_ < 0 || ::fchmod(fd_, 0711) != 0) {
    const int e = errno;
    removeTree(path_);
    throw lbpkit::Error(fmt::format("cannot open the run's folder {}: {}", name, std::strerror(e)));
  }
}

RunFolder::~RunFolder() {
  if (fd_ >= 0) ::close(fd_);
  removeTree(path_);
}

fs::path RunFolder::makeFolder(const std::string& name, mode_t mode, const RunAs& owner) {
  if (::mkdirat(fd_, name.c_str(), 0700) != 0)
    throw lbpkit::Error(fmt::format("cannot make {}: {}", (path_ / name).string(), std::strerror(errno)));
  const int fd = ::openat(fd_, name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  const bool ok = fd >= 0 && ::fchown(fd, owner.uid, owner.gid) == 0 && ::fchmod(fd, mode) == 0;
  const int e = errno;
  if (fd >= 0) ::close(fd);
  if (!ok) throw lbpkit::Error(fmt::format("cannot set up {}: {}", (path_ / name).string(), std::strerror(e)));
  return path_ / name;
}

fs::path RunFolder::writeFile(const std::string& name, const std::string& text) {
  const int fd = ::openat(fd_, name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) throw lbpkit::Error(fmt::format("cannot make {}: {}", (path_ / name).string(), std::strerror(errno)));
  std::size_t done = 0;
  while (done < text.size()) {
    const auto n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      ::close(fd);
      throw lbpkit::Error(fmt::format("cannot write {}", (path_ / name).string()));
    }
    done += static_cast<std::size_t>(n);
  }
  ::close(fd);
  return path_ / name;
}

namespace {
// Empties the folder open at `fd` (and closes it), `depth` levels at most.
void emptyFolder(int fd, int depth) {
  DIR* d = ::fdopendir(fd);
  if (d == nullptr) {
    ::close(fd);
    return;
  }
  std::vector<std::string> names;
  while (const dirent* e = ::readdir(d))
    if (std::strcmp(e->d_name, ".") != 0 && std::strcmp(e->d_name, "..") != 0) names.emplace_back(e->d_name);
  const int at = ::dirfd(d);
  for (const auto& name : names) {
    struct stat st {};
    if (::fstatat(at, name.c_str(), &st, AT_SYMLINK_NOFOLLOW) != 0) continue;
    if (S_ISDIR(st.st_mode) && depth > 0) {
      const int sub = ::openat(at, name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
      if (sub >= 0) emptyFolder(sub, depth - 1);
      ::unlinkat(at, name.c_str(), AT_REMOVEDIR);
    } else {
      ::unlinkat(at, name.c_str(), 0);
    }
  }
  ::closedir(d);
}
}  // namespace

void removeTree(const fs::path& path) {
  if (path.empty()) return;
  const int parent = ::open(path.parent_path().c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (parent < 0) return;
  const auto name = path.filename().string();
  const int fd = ::openat(parent, name.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd >= 0) {
    emptyFolder(fd, 32);
    ::unlinkat(parent, name.c_str(), AT_REMOVEDIR);
  }
  ::close(parent);
}

bool runIsAlive(pid_t owner) {
  if (owner <= 0) return false;
  const fs::path proc = fmt::format("/proc/{}", owner);
  if (firstLine(proc / "comm") != "lbpkit") return false;
  std::ifstream in(proc / "cmdline");
  std::string word;
  while (std::getline(in, word, '\0'))
    if (word == "linuxcnc") return true;
  return false;
}

void removeDeadRuns() {
  static const std::regex netnsName(R"(lbpkit-linuxcnc-(\d{1,9}))");
  static const std::regex link(R"(lbl(\d{1,9}))");
  static const std::regex folder(R"(lbpkit-linuxcnc-(\d{1,9})(-[A-Za-z0-9]{6})?)");
  auto owner = [](const std::smatch& m) { return static_cast<pid_t>(std::stol(m[1].str())); };
  std::error_code ec;
  std::smatch m;
  for (const auto& e : fs::directory_iterator("/run/netns", ec)) {
    const auto name = e.path().filename().string();
    if (std::regex_match(name, m, netnsName) && !runIsAlive(owner(m))) {
      const auto r = lbpkit::process::runProgram({"ip", "netns", "del", name});
      fmt::print("lbpkit linuxcnc: removed network namespace {}, left by a run that is gone (pid {}){}\n", name,
                 owner(m), r.status == 0 ? "" : ": " + r.output);
    }
  }
  for (const auto& e : fs::directory_iterator("/sys/class/net", ec)) {
    const auto name = e.path().filename().string();
    if (std::regex_match(name, m, link) && !runIsAlive(owner(m))) {
      (void)lbpkit::process::runProgram({"ip", "link", "del", name});
      fmt::print("lbpkit linuxcnc: removed link {}, left by a run that is gone (pid {})\n", name, owner(m));
    }
  }
  // The owners first, then their folders: nothing is removed from /tmp
  // while it is being read.
  std::set<pid_t> gone;
  for (const auto& e : fs::directory_iterator("/tmp", ec)) {
    const auto name = e.path().filename().string();
    if (std::regex_match(name, m, folder) && !runIsAlive(owner(m))) gone.insert(owner(m));
  }
  for (const pid_t pid : gone)
    for (const auto& removed : removeRunFolders(pid))
      fmt::print("lbpkit linuxcnc: removed folder {}, left by a run that is gone (pid {})\n", removed, pid);
}

std::vector<std::string> removeRunFolders(pid_t owner) {
  const std::string prefix = fmt::format("lbpkit-linuxcnc-{}", owner);
  std::vector<std::string> removed;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator("/tmp", ec)) {
    const auto name = e.path().filename().string();
    struct stat st {};
    // Only a real folder of root's: a name anyone could have made in /tmp
    // is not taken for a run's.
    if ((name == prefix || (name.size() == prefix.size() + 7 && name.rfind(prefix + "-", 0) == 0)) &&
        ::lstat(e.path().c_str(), &st) == 0 && S_ISDIR(st.st_mode) && st.st_uid == 0)
      removed.push_back(e.path().string());
  }
  for (const auto& path : removed) removeTree(path);  // once /tmp has been read
  return removed;
}

namespace {
struct Route {
  std::string device;
  std::uint32_t destination = 0, gateway = 0, mask = 0;  // host byte order
  bool viaGateway = false;
};
// The main routing table (/proc/net/route: its addresses in network byte
// order, as hex).
std::vector<Route> routes() {
  std::vector<Route> all;
  std::ifstream in("/proc/net/route");
  std::string line;
  std::getline(in, line);  // the heading
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string device, destination, gateway, flags, refs, use, metric, mask;
    if (!(fields >> device >> destination >> gateway >> flags >> refs >> use >> metric >> mask)) continue;
    auto hex = [](const std::string& t) { return ntohl(static_cast<std::uint32_t>(std::stoul(t, nullptr, 16))); };
    try {
      all.push_back({device, hex(destination), hex(gateway), hex(mask),
                     (std::stoul(flags, nullptr, 16) & RTF_GATEWAY) != 0});
    } catch (const std::exception&) {
    }
  }
  return all;
}
struct InterfaceAddress {
  std::string device;
  std::uint32_t address = 0;
};
std::vector<InterfaceAddress> interfaceAddresses() {
  std::vector<InterfaceAddress> all;
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return all;
  for (const ifaddrs* i = list; i != nullptr; i = i->ifa_next)
    if (i->ifa_addr != nullptr && i->ifa_addr->sa_family == AF_INET)
      all.push_back({i->ifa_name, ntohl(reinterpret_cast<const sockaddr_in*>(i->ifa_addr)->sin_addr.s_addr)});
  ::freeifaddrs(list);
  return all;
}
// "another lbpkit linuxcnc's (pid N, ...)" when `device` is a live run's link.
std::string whoseLink(const std::string& device) {
  static const std::regex link(R"(lbl(\d{1,9}))");
  std::smatch m;
  if (std::regex_match(device, m, link)) {
    const auto pid = static_cast<pid_t>(std::stol(m[1].str()));
    if (runIsAlive(pid))
      return fmt::format(": the card of another lbpkit linuxcnc (pid {}, network namespace {}); stop that one first, or "
                         "give this configuration another address",
                         pid, namespaceName(pid));
  }
  return {};
}
bool taken(std::uint32_t a, const std::vector<InterfaceAddress>& addresses, const std::vector<Route>& table) {
  for (const auto& i : addresses)
    if (i.address == a) return true;
  for (const auto& r : table)
    if ((r.viaGateway && r.gateway == a) || (r.mask == 0xFFFFFFFFU && r.destination == a)) return true;
  return false;
}
}  // namespace

std::optional<std::string> hostAddressProblem(Ipv4 board) {
  const auto text = lbpkit::linuxcnc::formatIpv4(board);
  for (const auto& i : interfaceAddresses())
    if (i.address == board.value) {
      const auto run = whoseLink(i.device);
      return run.empty() ? fmt::format("{} is this PC's own address (on {}): the card needs an address of its own", text,
                                       i.device)
                         : text + " is in use" + run;
    }
  for (const auto& r : routes()) {
    if (r.viaGateway && r.gateway == board.value)
      return fmt::format("{} is this PC's gateway (its route to {}/{} on {}): the card needs an address no other host has",
                         text, lbpkit::linuxcnc::formatIpv4({r.destination}), std::popcount(r.mask), r.device);
    if (r.mask == 0xFFFFFFFFU && r.destination == board.value) {
      const auto run = whoseLink(r.device);
      return run.empty() ? fmt::format("{} is already routed by this PC (a /32 on {})", text, r.device)
                         : text + " is in use" + run;
    }
  }
  return std::nullopt;
}

std::optional<Ipv4> peerFor(Ipv4 board) {
  const auto addresses = interfaceAddresses();
  const auto table = routes();
  for (std::uint32_t host = 2; host < 255; ++host) {
    const std::uint32_t candidate = (board.value & 0xFFFFFF00U) | host;
    if (candidate != board.value && !taken(candidate, addresses, table)) return Ipv4{candidate};
  }
  return std::nullopt;
}

void startReaper(pid_t owner, const std::string& netns, const std::string& link) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw lbpkit::Error("cannot make the reaper's pipe");
  gOwnPidNamespace = ::open("/proc/self/ns/pid", O_RDONLY | O_CLOEXEC);
  if (gOwnPidNamespace < 0 || ::unshare(CLONE_NEWPID) != 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw lbpkit::Error(fmt::format("cannot make a PID namespace for the run: {}", std::strerror(errno)));
  }
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t pid = ::fork();
  if (pid < 0) throw lbpkit::Error("cannot start the run's reaper: fork failed");
  if (pid == 0) {
    // PID 1 of the run's PID namespace: every process the run starts is in
    // it, and whoever of them loses its parent becomes this one's child.
    ::close(fds[1]);
    ::setpgid(0, 0);  // a terminal's Ctrl-C is for lbpkit, which stops the run in order
    const int null = ::open("/dev/null", O_RDWR | O_CLOEXEC);
    if (null >= 0) {
      ::dup2(null, 0);
      ::dup2(null, 1);
    }
    while (true) {
      pollfd p{fds[0], POLLIN, 0};
      if (::poll(&p, 1, 1000) > 0) {
        char c = 0;
        const auto n = ::read(fds[0], &c, 1);
        if (n == 0 || (n < 0 && errno != EINTR)) break;  // lbpkit linuxcnc ended, however
      }
      while (::waitpid(-1, nullptr, WNOHANG) > 0) {
      }
    }
    ::kill(-1, SIGKILL);  // from a namespace's PID 1: every other process in it
    while (::waitpid(-1, nullptr, 0) > 0 || errno == EINTR) {
    }
    if (fs::exists("/sys/class/net/" + link)) (void)lbpkit::process::runProgram({"ip", "link", "del", link});
    if (fs::exists("/run/netns/" + netns)) (void)lbpkit::process::runProgram({"ip", "netns", "del", netns});
    (void)removeRunFolders(owner);
    ::_exit(0);
  }
  ::close(fds[0]);
  gReaperPipe = fds[1];
  // This process starts threads of its own later (a thread must be in the
  // PID namespace its process's children go to): children go to the run's
  // namespace only when forkInRun() starts one.
  gRunPidNamespace = ::open("/proc/self/ns/pid_for_children", O_RDONLY | O_CLOEXEC);
  if (gRunPidNamespace < 0 || ::setns(gOwnPidNamespace, CLONE_NEWPID) != 0)
    throw lbpkit::Error(fmt::format("cannot keep the run's PID namespace: {}", std::strerror(errno)));
}

pid_t forkInRun() {
  if (gRunPidNamespace < 0) return ::fork();
  std::fflush(stdout);
  std::fflush(stderr);
  if (::setns(gRunPidNamespace, CLONE_NEWPID) != 0) return -1;
  const pid_t pid = ::fork();
  if (pid != 0) ::setns(gOwnPidNamespace, CLONE_NEWPID);
  if (pid == 0 && gReaperPipe >= 0) ::close(gReaperPipe);
  return pid;
}

int reaperPipe() { return gReaperPipe; }

int openUsersFile(const fs::path& path, uid_t owner, struct stat& st) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return -1;
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || st.st_uid != owner) {
    ::close(fd);
    return -1;
  }
  return fd;
}

std::optional<std::string> readUsersFile(const fs::path& path, uid_t owner, std::chrono::system_clock::time_point notBefore,
                                         std::size_t limit) {
  struct stat st {};
  const int fd = openUsersFile(path, owner, st);
  if (fd < 0) return std::nullopt;
  if (std::chrono::system_clock::time_point(std::chrono::seconds(st.st_mtim.tv_sec + 1)) < notBefore) {
    ::close(fd);
    return std::nullopt;
  }
  const auto size = static_cast<std::size_t>(st.st_size);
  if (size > limit) ::lseek(fd, static_cast<off_t>(size - limit), SEEK_SET);
  std::string text(std::min(size, limit), '\0');
  std::size_t done = 0;
  while (done < text.size()) {
    const auto n = ::read(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    done += static_cast<std::size_t>(n);
  }
  ::close(fd);
  text.resize(done);
  return text;
}

}  // namespace lbpkit::app::linuxcnc_run
