// SPDX-License-Identifier: MIT
// An X server of a test's own (Xvfb), the desktop a user runs LinuxCNC from:
// AXIS, hal_manualtoolchange's window and LinuxCNC's error dialog need one.
// On a display number Xvfb finds free, stopped with the object.
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>


namespace test_support {

class Xvfb {
 public:
  // Xvfb chooses the display number itself (-displayfd: the lowest free one
  // from 1 on, claimed by its lock file, so tests started side by side never
  // share one) and writes it to the pipe once it accepts clients.
  Xvfb() {
    int ready[2];
    if (::pipe2(ready, O_CLOEXEC) != 0) return;
    pid_ = ::fork();
    if (pid_ == 0) {
      // A test killed outright (ctest's timeout) takes its X server along.
      ::prctl(PR_SET_PDEATHSIG, SIGTERM);
      const int null = ::open("/dev/null", O_WRONLY);
      ::dup2(null, 1);
      ::dup2(null, 2);
      ::dup2(ready[1], 3);  // dup2 clears close-on-exec on the copy
      ::execlp("Xvfb", "Xvfb", "-displayfd", "3", "-screen", "0", "1024x768x24", "-nolisten", "tcp",
               static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ::close(ready[1]);
    std::string number;
    pollfd p{ready[0], POLLIN, 0};
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    while (pid_ > 0 && !number.ends_with('\n')) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now()).count();
      if (left <= 0 || ::poll(&p, 1, static_cast<int>(left)) <= 0) break;
      char buf[16];
      const auto n = ::read(ready[0], buf, sizeof buf);
      if (n <= 0) break;  // Xvfb exited without a display
      number.append(buf, static_cast<std::size_t>(n));
    }
    ::close(ready[0]);
    if (!number.ends_with('\n') || number.size() < 2) return;
    number.pop_back();
    display_ = ":" + number;
    up_ = ::waitpid(pid_, nullptr, WNOHANG) == 0;
  }
  ~Xvfb() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  Xvfb(const Xvfb&) = delete;
  Xvfb& operator=(const Xvfb&) = delete;

  [[nodiscard]] bool up() const { return up_; }
  // ":N", for DISPLAY.
  [[nodiscard]] const std::string& display() const { return display_; }

 private:
  std::string display_;
  pid_t pid_ = -1;
  bool up_ = false;
};

}  // namespace test_support
