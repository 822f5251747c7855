// SPDX-License-Identifier: MIT
#include "linuxcnc/linuxcnc_root.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string_view>
#include <vector>

namespace lbpkit::linuxcnc {

namespace {

std::string failed(const std::string& what) { return what + ": " + std::strerror(errno); }

}  // namespace

bool isSystemFolder(const std::string& name) {
  static constexpr std::array<std::string_view, 12> kSystem = {
      "usr", "etc", "var", "opt", "bin", "sbin", "lib", "lib32", "lib64", "libx32", "boot", "lost+found"};
  for (const auto s : kSystem)
    if (name == s) return true;
  return false;
}

std::string linuxCncRootProblem(const std::string& root) {
  if (root.empty() || root.front() != '/') return root + ": not an absolute path";
  std::unique_ptr<char, decltype(&std::free)> real(::realpath(root.c_str(), nullptr), &std::free);
  if (!real) return failed(root);
  if (std::string(real.get()) != root) return root + ": a path through a link or with . or .. (" + real.get() + ")";
  // Each folder from / down to the root: root's, and writable by root alone.
  for (std::string::size_type end = 0; end != std::string::npos;) {
    end = root.find('/', end + 1);
    const std::string folder = end == std::string::npos ? root : (end == 0 ? "/" : root.substr(0, end));
    struct stat st {};
    if (::lstat(folder.c_str(), &st) != 0) return failed(root + ": " + folder);
    if (!S_ISDIR(st.st_mode)) return root + ": " + folder + " is not a folder";
    if (st.st_uid != 0 || (st.st_mode & (S_IWGRP | S_IWOTH)) != 0)
      return root + ": " + folder +
             " is not root's own, or another user may write to it (a LinuxCNC root is entered as root)";
  }
  struct stat st {};
  if (::stat((root + "/usr/bin/linuxcnc").c_str(), &st) != 0 || !S_ISREG(st.st_mode))
    return root + ": no /usr/bin/linuxcnc in it (a Debian root with linuxcnc-uspace: scripts/linuxcnc-releases)";
  return {};
}

std::string enterLinuxCncRoot(const std::string& root) {
  if (auto problem = linuxCncRootProblem(root); !problem.empty()) return problem;
  if (::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0) return failed("a private mount namespace");
  std::array<char, PATH_MAX> cwd{};
  const bool haveCwd = ::getcwd(cwd.data(), cwd.size()) != nullptr;
  // This PC's folders, the system's excepted, each bound (with what is
  // mounted under it) onto the root's folder of that name, made when the
  // root has none.
  DIR* top = ::opendir("/");
  if (top == nullptr) return failed("/");
  std::vector<std::string> folders;
  while (const dirent* e = ::readdir(top)) {
    const std::string name = e->d_name;
    if (name == "." || name == ".." || isSystemFolder(name)) continue;
    struct stat st {};
    if (::lstat(("/" + name).c_str(), &st) == 0 && S_ISDIR(st.st_mode)) folders.push_back(name);
  }
  ::closedir(top);
  const int rootFd = ::open(root.c_str(), O_PATH | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (rootFd < 0) return failed(root);
  std::string problem;
  for (const auto& name : folders) {
    struct stat st {};
    if (::fstatat(rootFd, name.c_str(), &st, AT_SYMLINK_NOFOLLOW) != 0) {
      if (::mkdirat(rootFd, name.c_str(), 0755) != 0) {
        problem = failed(root + "/" + name);
        break;
      }
    } else if (!S_ISDIR(st.st_mode)) {
      continue;  // the root has its own idea of this name (a link): left as it is
    }
    const int to = ::openat(rootFd, name.c_str(), O_PATH | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
    if (to < 0) {
      problem = failed(root + "/" + name);
      break;
    }
    const std::string target = "/proc/self/fd/" + std::to_string(to);
    const bool bound = ::mount(("/" + name).c_str(), target.c_str(), nullptr, MS_BIND | MS_REC, nullptr) == 0;
    if (!bound) problem = failed("/" + name + " into " + root);
    ::close(to);
    if (!bound) break;
  }
  if (problem.empty() && (::fchdir(rootFd) != 0 || ::chroot(".") != 0)) problem = failed("entering " + root);
  ::close(rootFd);
  if (!problem.empty()) return problem;
  if (!haveCwd || ::chdir(cwd.data()) != 0) (void)!::chdir("/");
  return {};
}

}  // namespace lbpkit::linuxcnc
