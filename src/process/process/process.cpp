// SPDX-License-Identifier: MIT
#include "process/process.hpp"

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <spawn.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace lbpkit::process {

std::optional<std::string> systemProgram(std::string_view name, const std::string& root) {
  if (name.empty() || name.find('/') != std::string_view::npos) return std::nullopt;
  for (const auto folder : kSystemFolders) {
    std::string path = std::string(folder) + "/" + std::string(name);
    struct stat st {};
    const std::string there = root + path;
    if (::stat(there.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::access(there.c_str(), X_OK) == 0) return path;
  }
  return std::nullopt;
}

ProgramResult runProgram(const std::vector<std::string>& argv) {
  ProgramResult result;
  if (argv.empty()) return result;
  std::string path = argv.front();
  if (path.find('/') == std::string::npos) {
    const auto found = systemProgram(path);
    if (!found) {
      result.output = path + " is not installed (looked for in /usr/sbin, /usr/bin, /sbin, /bin)";
      return result;
    }
    path = *found;
  }
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) {
    result.output = std::string("cannot make a pipe: ") + std::strerror(errno);
    return result;
  }
  posix_spawn_file_actions_t actions;
  ::posix_spawn_file_actions_init(&actions);
  ::posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  ::posix_spawn_file_actions_adddup2(&actions, fds[1], 1);
  ::posix_spawn_file_actions_adddup2(&actions, fds[1], 2);
  std::vector<char*> args;
  args.reserve(argv.size() + 1);
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = -1;
  const int spawned = ::posix_spawn(&pid, path.c_str(), &actions, nullptr, args.data(), environ);
  ::posix_spawn_file_actions_destroy(&actions);
  ::close(fds[1]);
  if (spawned != 0) {
    ::close(fds[0]);
    result.output = "cannot start " + path + ": " + std::strerror(spawned);
    return result;
  }
  std::array<char, 512> buf{};
  for (ssize_t n; (n = ::read(fds[0], buf.data(), buf.size())) != 0;) {
    if (n < 0) {
      if (errno == EINTR) continue;
      break;
    }
    result.output.append(buf.data(), static_cast<std::size_t>(n));
  }
  ::close(fds[0]);
  const int status = reap(pid);
  result.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

pid_t spawn(const std::vector<std::string>& argv, const SpawnOptions& o) {
  if (argv.empty()) throw std::runtime_error("spawn: no program");
  // Made before the fork: the child only calls what is safe after one.
  std::vector<char*> args;
  args.reserve(argv.size() + 1);
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t parent = ::getpid();
  const pid_t pid = o.fork != nullptr ? o.fork() : ::fork();
  if (pid < 0) throw std::runtime_error(std::string("cannot start ") + argv.front() + ": fork failed");
  if (pid > 0) {
    if (o.ownProcessGroup) ::setpgid(pid, pid);
    return pid;
  }
  if (o.ownProcessGroup) ::setpgid(0, 0);
  if (o.deathSignal != 0) {
    ::prctl(PR_SET_PDEATHSIG, o.deathSignal);
    // The parent gone already (a child forked into another PID namespace
    // sees its parent as 0).
    const pid_t now = ::getppid();
    if (now != parent && now != 0) ::_exit(127);
  }
  if (o.cpu) pinToCpu(*o.cpu);
  if (o.nullStdin) {
    const int null = ::open("/dev/null", O_RDONLY);
    if (null >= 0 && null != 0) {
      ::dup2(null, 0);
      ::close(null);
    }
  }
  if (o.out >= 0) {
    ::dup2(o.out, 1);
    if (o.err == -2) ::dup2(o.out, 2);
  }
  if (o.err >= 0) ::dup2(o.err, 2);
  if (o.ready >= 0) ::dup2(o.ready, 3);
  // Kept across the exec even where a descriptor was its own target (dup2
  // then leaves its close-on-exec flag as it was).
  for (const int fd : {1, 2, 3})
    if ((fd == 1 && o.out >= 0) || (fd == 2 && (o.err >= 0 || o.out >= 0)) || (fd == 3 && o.ready >= 0))
      ::fcntl(fd, F_SETFD, 0);
  ::execv(args[0], args.data());
  ::_exit(127);
}

int reap(pid_t pid) {
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return status;
}

int stopWithGrace(pid_t pid, std::chrono::milliseconds grace, int signal, bool group, bool* killed) {
  if (killed != nullptr) *killed = false;
  if (pid <= 0) return -1;
  ::kill(pid, signal);
  const auto deadline = std::chrono::steady_clock::now() + grace;
  int status = 0;
  pid_t got = 0;
  while ((got = ::waitpid(pid, &status, WNOHANG)) == 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  if (got == 0) {
    if (group) ::kill(-pid, SIGKILL);
    ::kill(pid, SIGKILL);
    if (killed != nullptr) *killed = true;
    got = ::waitpid(pid, &status, 0);
  }
  if (got != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::vector<unsigned> allowedCpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  std::vector<unsigned> cpus;
  if (::sched_getaffinity(0, sizeof set, &set) != 0) return cpus;
  for (unsigned i = 0; i < CPU_SETSIZE; ++i)
    if (CPU_ISSET(i, &set)) cpus.push_back(i);
  return cpus;
}

bool pinToCpu(unsigned cpu) {
  if (cpu >= CPU_SETSIZE) return false;
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  return ::sched_setaffinity(0, sizeof set, &set) == 0;
}

std::optional<unsigned> parseCpu(const std::string& text, std::string_view option) {
  const auto cpus = allowedCpus();
  if (text == "any") return std::nullopt;
  if (text == "last") {
    if (cpus.empty()) return std::nullopt;
    return cpus.back();
  }
  const bool digits = !text.empty() && text.size() <= 4 && text.find_first_not_of("0123456789") == std::string::npos;
  std::string list;
  for (const unsigned c : cpus) list += (list.empty() ? "" : ", ") + std::to_string(c);
  if (!digits)
    throw std::invalid_argument(std::string(option) + " " + text + ": give a CPU's number, last or any (this process may use " +
                                list + ")");
  const auto n = static_cast<unsigned>(std::stoul(text));
  for (const unsigned c : cpus)
    if (c == n) return n;
  throw std::invalid_argument(std::string(option) + " " + text + ": not a CPU this process may run on (those are " +
                              list + ")");
}

}  // namespace lbpkit::process
