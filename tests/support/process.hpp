// SPDX-License-Identifier: MIT
// lbpkit as an external program: run to completion, or kept running (a
// daemon) and stopped as a user stops it when the test is done.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <vector>

#include "process/process.hpp"

namespace test_support {

struct Result {
  int exit = -1;
  std::string out;
  std::string err;
};

// lbpkit ARGS with its output and errors into pipes (outFd, errFd: their
// read ends); `readyFd` given: a third pipe whose write end the child has as
// descriptor 3 (for `--ready-fd 3`), its read end in *readyFd.
inline pid_t spawn(const std::vector<std::string>& args, int& outFd, int& errFd, int* readyFd = nullptr) {
  int out[2], err[2], ready[2] = {-1, -1};
  if (::pipe2(out, O_CLOEXEC) != 0 || ::pipe2(err, O_CLOEXEC) != 0) throw std::runtime_error("pipe");
  if (readyFd != nullptr && ::pipe2(ready, O_CLOEXEC) != 0) throw std::runtime_error("pipe");
  // LBPKIT_BINARY in the environment: another build's lbpkit (scripts/test
  // runs these tests against the ThreadSanitizer build's daemon).
  static const std::string bin =
      std::getenv("LBPKIT_BINARY") != nullptr ? std::getenv("LBPKIT_BINARY") : LBPKIT_BINARY;
  std::vector<std::string> argv = {bin};
  argv.insert(argv.end(), args.begin(), args.end());
  lbpkit::process::SpawnOptions o;
  o.out = out[1];
  o.err = err[1];
  o.ready = ready[1];
  o.nullStdin = false;
  // A test that aborts (a sanitizer's report) must not leave its sim
  // behind to hold the address the next test binds.
  o.deathSignal = SIGTERM;
  const pid_t pid = lbpkit::process::spawn(argv, o);
  ::close(out[1]);
  ::close(err[1]);
  outFd = out[0];
  errFd = err[0];
  if (readyFd != nullptr) {
    ::close(ready[1]);
    *readyFd = ready[0];
  }
  return pid;
}

// Appends what `fd` gives to `text` until `text` holds `marker` (at `from`
// or after) and the end of its line (or `fd` closes, or `limit` passes);
// returns `text`.
inline std::string& readUntil(int fd, std::string& text, const std::string& marker, std::chrono::milliseconds limit,
                              std::size_t from = 0) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < deadline) {
    const auto at = text.find(marker, from);
    if (at != std::string::npos && text.find('\n', at) != std::string::npos) break;
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;
    char buf[4096];
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n <= 0) break;
    text.append(buf, static_cast<std::size_t>(n));
  }
  return text;
}

// Runs lbpkit to completion (killed after `limit`).
inline Result run(const std::vector<std::string>& args, std::chrono::seconds limit = std::chrono::seconds(60)) {
  int outFd = -1, errFd = -1;
  const pid_t pid = spawn(args, outFd, errFd);
  Result r;
  const auto deadline = std::chrono::steady_clock::now() + limit;
  bool outOpen = true, errOpen = true;
  while ((outOpen || errOpen) && std::chrono::steady_clock::now() < deadline) {
    pollfd p[2] = {{outOpen ? outFd : -1, POLLIN, 0}, {errOpen ? errFd : -1, POLLIN, 0}};
    if (::poll(p, 2, 100) <= 0) continue;
    char buf[4096];
    for (int i = 0; i < 2; ++i) {
      if (!(p[i].revents & (POLLIN | POLLHUP))) continue;
      const ssize_t n = ::read(i == 0 ? outFd : errFd, buf, sizeof buf);
      if (n <= 0) (i == 0 ? outOpen : errOpen) = false;
      else (i == 0 ? r.out : r.err).append(buf, static_cast<std::size_t>(n));
    }
  }
  if (outOpen || errOpen) ::kill(pid, SIGKILL);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ::close(outFd);
  ::close(errFd);
  r.exit = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// The 7I77's own watchdog (50 ms, manual: WATCHDOG AND FAULTS) bites when
// its processor hears nothing from the host for that long: a test's host
// held back by a busy machine looks like a host that stalled. Tests that are
// not about that watchdog give the processors this working WatchDogTime.
inline constexpr const char* kPatient7i77WatchdogMs = "500";

// WatchDogTime `ms` for the processors on these smart-serial channels (0:
// the first 7I77's field I/O, 1: its analog side) of the card at `address`
// (HOST or HOST:PORT), through `lbpkit wpd` as Mesa's WPD sets it: empty
// when every write was taken, else the channel and lbpkit's error.
inline std::string patient7i77Watchdogs(const std::string& address, std::initializer_list<unsigned> channels,
                                        const char* ms = kPatient7i77WatchdogMs) {
  for (const unsigned channel : channels) {
    const auto w = run({"wpd", "WATCHDOGTIME", ms, "--addr", address, "--channel", std::to_string(channel)});
    if (w.exit != 0) return "channel " + std::to_string(channel) + ": " + w.err;
  }
  return {};
}

// A long-running lbpkit (a daemon) that is stopped when the test ends.
class Daemon {
 public:
  // `ready`: it is given a pipe as descriptor 3 for its greeting (the
  // caller puts `--ready-fd 3` in args; readyLine() reads it).
  explicit Daemon(const std::vector<std::string>& args, bool ready = false) {
    pid_ = spawn(args, out_, err_, ready ? &ready_ : nullptr);
  }
  // Stopped as a user stops it (SIGTERM), so that it closes its state files
  // and removes their owner notes; killed if it has not gone within 10 s.
  ~Daemon() {
    if (pid_ > 0) (void)stopWithin(std::chrono::seconds(10));
    ::close(out_);
    ::close(err_);
    if (ready_ >= 0) ::close(ready_);
  }
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  // Output up to a line containing `marker` (10 s at most), looking from
  // the output's `from`th character on.
  std::string readUntil(const std::string& marker, std::size_t from = 0) {
    return test_support::readUntil(out_, text_, marker, std::chrono::seconds(10), from);
  }
  // The same for its standard error (its warnings).
  std::string readErrUntil(const std::string& marker, std::size_t from = 0) {
    return test_support::readUntil(err_, errText_, marker, std::chrono::seconds(10), from);
  }
  // Its greeting on the ready pipe: the first line, or "" when it closed
  // the pipe without one (it did not start) or `limit` passed.
  std::string readyLine(std::chrono::milliseconds limit = std::chrono::seconds(15)) {
    std::string line;
    const auto deadline = std::chrono::steady_clock::now() + limit;
    while (ready_ >= 0 && line.find('\n') == std::string::npos && std::chrono::steady_clock::now() < deadline) {
      pollfd p{ready_, POLLIN, 0};
      if (::poll(&p, 1, 100) <= 0) continue;
      char buf[4096];
      const ssize_t n = ::read(ready_, buf, sizeof buf);
      if (n <= 0) break;
      line.append(buf, static_cast<std::size_t>(n));
    }
    const auto end = line.find('\n');
    return end == std::string::npos ? std::string() : line.substr(0, end);
  }
  // The rest of a line after `marker`.
  std::string value(const std::string& marker) {
    const std::string t = readUntil(marker);
    const auto at = t.find(marker);
    if (at == std::string::npos) return {};
    return t.substr(at + marker.size(), t.find('\n', at) - at - marker.size());
  }
  // Like stop(), but gives up after `limit`: returns -2 (and SIGKILLs it)
  // when the daemon ignored the signal, so a wedged daemon fails the test
  // instead of hanging it.
  int stopWithin(std::chrono::milliseconds limit, int sig = SIGTERM) {
    bool killed = false;
    const int status = lbpkit::process::stopWithGrace(pid_, limit, sig, false, &killed);
    pid_ = -1;
    if (killed) return -2;
    return status >= 128 ? -1 : status;
  }
  [[nodiscard]] pid_t pid() const { return pid_; }
  int stop(int sig = SIGTERM) {
    if (pid_ <= 0) return -1;  // never kill(-1, ...): every process there is
    ::kill(pid_, sig);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

 private:
  pid_t pid_ = -1;
  int out_ = -1, err_ = -1, ready_ = -1;
  std::string text_;
  std::string errText_;
};

}  // namespace test_support
