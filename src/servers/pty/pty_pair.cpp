// SPDX-License-Identifier: MIT
#include "pty/pty_pair.hpp"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include "lbpkit/wire/serial_speed.hpp"

namespace lbpkit::server {

std::runtime_error systemError(const std::string& what) { return std::runtime_error(what + ": " + std::strerror(errno)); }

namespace {

// A pty takes any rate; one termios cannot name reads back as 115200.
speed_t speedFor(std::uint32_t baud) {
  return static_cast<speed_t>(lbpkit::wire::termiosSpeed(baud).value_or(B115200));
}

}  // namespace

PtyPair::PtyPair(std::uint32_t baud) {
  master_ = ::posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (master_ < 0) throw systemError("cannot open a pseudo-terminal");
  try {
    if (::grantpt(master_) != 0 || ::unlockpt(master_) != 0) throw systemError("cannot unlock the pseudo-terminal");
    const char* name = ::ptsname(master_);
    if (name == nullptr) throw systemError("cannot name the pseudo-terminal");
    path_ = name;
    // Non-blocking: a client that never reads must not stop the server (or
    // its SIGTERM handling) in write().
    if (::fcntl(master_, F_SETFL, ::fcntl(master_, F_GETFL) | O_NONBLOCK) != 0)
      throw systemError("cannot make the pseudo-terminal non-blocking");
    slave_ = ::open(path_.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (slave_ < 0) throw systemError("cannot open " + path_);
  } catch (...) {
    if (master_ >= 0) ::close(master_);
    throw;
  }
  termios tio{};
  if (::tcgetattr(slave_, &tio) == 0) {
    ::cfmakeraw(&tio);
    ::cfsetspeed(&tio, speedFor(baud));
    ::tcsetattr(slave_, TCSANOW, &tio);
  }
}

PtyPair::~PtyPair() {
  if (slave_ >= 0) ::close(slave_);
  if (master_ >= 0) ::close(master_);
}

}  // namespace lbpkit::server
