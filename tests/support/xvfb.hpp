// SPDX-License-Identifier: MIT
// An X server of a test's own (Xvfb), the desktop a user runs LinuxCNC from:
// AXIS, hal_manualtoolchange's window and LinuxCNC's error dialog need one.
// Started on a display number no X server on this PC uses, stopped with the
// object.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>

#include "support/process.hpp"
#include "support/wait.hpp"

namespace test_support {

class Xvfb {
 public:
  Xvfb() {
    for (int n = 90; n < 190 && display_.empty(); ++n)
      if (!std::filesystem::exists("/tmp/.X11-unix/X" + std::to_string(n)) &&
          !std::filesystem::exists("/tmp/.X" + std::to_string(n) + "-lock"))
        display_ = ":" + std::to_string(n);
    if (display_.empty()) return;
    pid_ = ::fork();
    if (pid_ == 0) {
      // A test killed outright (ctest's timeout) takes its X server along.
      ::prctl(PR_SET_PDEATHSIG, SIGTERM);
      const int null = ::open("/dev/null", O_WRONLY);
      ::dup2(null, 1);
      ::dup2(null, 2);
      ::execlp("Xvfb", "Xvfb", display_.c_str(), "-screen", "0", "1024x768x24", "-nolisten", "tcp",
               static_cast<char*>(nullptr));
      ::_exit(127);
    }
    // Up once its socket is there (Xvfb makes it when it accepts clients).
    up_ = waitFor(
        [&] {
          return std::filesystem::exists("/tmp/.X11-unix/X" + display_.substr(1)) && ::waitpid(pid_, nullptr, WNOHANG) == 0;
        },
        std::chrono::seconds(10));
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
