// SPDX-License-Identifier: MIT
#include "linuxcnc/network_namespace.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <utility>

#include "lbpkit/error.hpp"
#include "process/process.hpp"

namespace lbpkit::linuxcnc {

namespace {
// Runs `ip` with `args` (by an argument vector: process/process.hpp): its
// exit status and what it printed.
process::ProgramResult ip(std::vector<std::string> args) {
  args.insert(args.begin(), "ip");
  return process::runProgram(args);
}

std::string joined(const std::vector<std::string>& words) {
  std::string text = "ip";
  for (const auto& w : words) text += " " + w;
  return text;
}
}  // namespace

AddressClaim::AddressClaim(const std::string& lockFile) {
  fd_ = ::open(lockFile.c_str(), O_RDWR | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0600);
  const int opened = errno;
  struct stat st {};
  if (fd_ < 0) throw Error("cannot claim the run's addresses: " + lockFile + ": " + std::strerror(opened));
  if (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode) || st.st_uid != 0) {
    ::close(fd_);
    throw Error("cannot claim the run's addresses: " + lockFile + " is not a file of root's");
  }
  while (::flock(fd_, LOCK_EX) != 0)
    if (errno != EINTR) {
      const int error = errno;
      ::close(fd_);
      throw Error("cannot claim the run's addresses: flock " + lockFile + ": " + std::strerror(error));
    }
}

AddressClaim::~AddressClaim() { ::close(fd_); }  // and the lock with it

NetworkNamespace::NetworkNamespace(std::string name, std::vector<VethLink> links)
    : name_(std::move(name)), links_(std::move(links)) {
  std::vector<std::vector<std::string>> commands = {{"netns", "add", name_}, {"-n", name_, "link", "set", "lo", "up"}};
  for (const auto& l : links_) {
    const std::string inside = l.name + "h";
    commands.push_back({"link", "add", l.name, "type", "veth", "peer", "name", inside});
    commands.push_back({"link", "set", inside, "netns", name_});
    commands.push_back({"addr", "add", l.outsideAddress, "dev", l.name});
    commands.push_back({"link", "set", l.name, "up"});
    const auto slash = l.outsideAddress.find('/');
    if (l.routeTo) commands.push_back({"route", "add", *l.routeTo, "dev", l.name, "src", l.outsideAddress.substr(0, slash)});
    commands.push_back({"-n", name_, "addr", "add", l.insideAddress, "dev", inside});
    commands.push_back({"-n", name_, "link", "set", inside, "up"});
  }
  for (const auto& c : commands) {
    const auto [status, out] = ip(c);
    if (status != 0) {
      remove();
      throw Error("cannot set up network namespace " + name_ + ": `" + joined(c) + "` said: " + out);
    }
  }
}

NetworkNamespace::~NetworkNamespace() { remove(); }

void NetworkNamespace::remove() {
  // Deleting one end of a veth pair deletes both; the namespace's own go with it.
  for (const auto& l : links_)
    if (std::filesystem::exists("/sys/class/net/" + l.name)) (void)ip({"link", "del", l.name});
  if (std::filesystem::exists("/run/netns/" + name_)) (void)ip({"netns", "del", name_});
}

bool NetworkNamespace::gone() const {
  if (std::filesystem::exists("/run/netns/" + name_)) return false;
  for (const auto& l : links_)
    if (std::filesystem::exists("/sys/class/net/" + l.name)) return false;
  return true;
}

unsigned long NetworkNamespace::inode() const {
  struct stat st {};
  return ::stat(("/run/netns/" + name_).c_str(), &st) == 0 ? static_cast<unsigned long>(st.st_ino) : 0;
}

std::string rtapiEnvironment(const std::string& fifo) {
  return "env RTAPI_UID=65534 RTAPI_FIFO_PATH=" + fifo + " ";
}

std::vector<std::string> rtapiSettings(const std::string& fifo) {
  return {"RTAPI_UID=65534", "RTAPI_FIFO_PATH=" + fifo};
}

}  // namespace lbpkit::linuxcnc
