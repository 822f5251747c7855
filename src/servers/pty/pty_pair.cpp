#include "pty/pty_pair.hpp"

#include <fcntl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace net {

std::runtime_error systemError(const std::string& what) { return std::runtime_error(what + ": " + std::strerror(errno)); }

namespace {

speed_t speedFor(std::uint32_t baud) {
  switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
    case 460800: return B460800;
    case 500000: return B500000;
    case 921600: return B921600;
    case 1000000: return B1000000;
    case 1500000: return B1500000;
    case 2000000: return B2000000;
    case 2500000: return B2500000;
    case 3000000: return B3000000;
    case 4000000: return B4000000;
    default: return B115200;
  }
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

}  // namespace net
