// SPDX-License-Identifier: MIT
#include "process/host_process.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <unistd.h>

#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <set>
#include <string>

namespace lbpkit::process {
namespace {

bool allDigits(const char* s) {
  if (*s == '\0') return false;
  for (; *s != '\0'; ++s)
    if (*s < '0' || *s > '9') return false;
  return true;
}

// The state letter of a /proc/.../stat file: the field after the command
// name, which is in parentheses and may itself hold ')' and spaces, so
// the last ')' ends it. '\0' when the file cannot be read.
char stateLetter(const std::string& statPath) {
  const int fd = ::open(statPath.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return '\0';
  char buf[256];
  const ssize_t n = ::read(fd, buf, sizeof buf - 1);
  ::close(fd);
  if (n <= 0) return '\0';
  buf[n] = '\0';
  const char* close = std::strrchr(buf, ')');
  if (close == nullptr || close[1] != ' ') return '\0';
  return close[2];
}

// Calls each(PID) for every process in /proc until it returns true.
template <typename Each>
void forEachProcess(Each&& each) {
  DIR* proc = ::opendir("/proc");
  if (proc == nullptr) return;
  while (const dirent* p = ::readdir(proc))
    if (allDigits(p->d_name) && each(p->d_name)) break;
  ::closedir(proc);
}

// The inodes of the UDP sockets in a /proc/net/udp list bound to `port`
// on `address` (into exact) or on any address (into anyAddress). The list
// is "sl local_address rem_address st ... uid timeout inode", addresses as
// the kernel holds them (the network-order word printed as a number) and
// ports in hex.
void udpSockets(const std::string& list, std::uint32_t address, std::uint16_t port, std::set<unsigned long>& exact,
                std::set<unsigned long>& anyAddress) {
  std::ifstream udp(list);
  std::string line;
  std::getline(udp, line);  // the heading
  while (std::getline(udp, line)) {
    unsigned localAddress = 0;
    unsigned localPort = 0;
    unsigned long inode = 0;
    // sl: local rem st tx:rx tr:when retrnsmt uid timeout inode
    if (std::sscanf(line.c_str(), " %*u: %x:%x %*x:%*x %*x %*x:%*x %*x:%*x %*x %*u %*u %lu", &localAddress, &localPort,
                    &inode) != 3)
      continue;
    if (localPort != port || inode == 0) continue;
    if (localAddress == address)
      exact.insert(inode);
    else if (localAddress == 0)
      anyAddress.insert(inode);
  }
}

}  // namespace

std::optional<pid_t> udpSocketOwner(std::uint32_t address, std::uint16_t port) {
  // The socket's inode, from each network namespace's list of UDP sockets
  // (/proc/PID/net/udp, read once a namespace): a host in a namespace of
  // its own (LinuxCNC under `lbpkit linuxcnc`, whose card is reached over
  // a veth pair) is found as one beside the sim.
  std::set<std::string> namespaces;
  std::set<unsigned long> exact;
  std::set<unsigned long> anyAddress;
  forEachProcess([&](const char* pid) {
    char ns[64];
    const std::string base = std::string("/proc/") + pid;
    const ssize_t n = ::readlink((base + "/ns/net").c_str(), ns, sizeof ns - 1);
    if (n <= 0 || !namespaces.emplace(ns, static_cast<std::size_t>(n)).second) return false;
    udpSockets(base + "/net/udp", address, port, exact, anyAddress);
    return false;
  });
  const auto& inodes = exact.empty() ? anyAddress : exact;
  if (inodes.empty()) return std::nullopt;
  std::optional<pid_t> owner;
  forEachProcess([&](const char* pid) {
    const std::string fdDir = std::string("/proc/") + pid + "/fd";
    DIR* fds = ::opendir(fdDir.c_str());
    if (fds == nullptr) return false;  // gone, or not ours to look into
    while (const dirent* f = ::readdir(fds)) {
      if (!allDigits(f->d_name)) continue;
      char link[64];
      const ssize_t n = ::readlinkat(::dirfd(fds), f->d_name, link, sizeof link - 1);
      if (n <= 0) continue;
      link[n] = '\0';
      unsigned long inode = 0;
      if (std::sscanf(link, "socket:[%lu]", &inode) == 1 && inodes.contains(inode)) {
        owner = static_cast<pid_t>(std::strtol(pid, nullptr, 10));
        break;
      }
    }
    ::closedir(fds);
    return owner.has_value();
  });
  return owner;
}

ThreadsState threadsState(pid_t pid) {
  const std::string base = "/proc/" + std::to_string(pid);
  const char main = stateLetter(base + "/stat");
  if (main == '\0' || main == 'Z' || main == 'X' || main == 'x') return ThreadsState::Gone;
  DIR* tasks = ::opendir((base + "/task").c_str());
  if (tasks == nullptr) return ThreadsState::Gone;
  bool stopped = false;
  bool runnable = false;
  while (const dirent* t = ::readdir(tasks)) {
    if (!allDigits(t->d_name)) continue;
    const char s = stateLetter(base + "/task/" + t->d_name + "/stat");
    if (s == 'R' || s == 'D') runnable = true;
    if (s == 'T' || s == 't') stopped = true;
  }
  ::closedir(tasks);
  if (runnable) return ThreadsState::Runnable;
  return stopped ? ThreadsState::Stopped : ThreadsState::Waiting;
}

}  // namespace lbpkit::process
