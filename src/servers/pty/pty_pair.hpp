// SPDX-License-Identifier: MIT
// A pseudo-terminal for a program that expects a serial port (a USB-RS422
// adapter's /dev/ttyUSB0): the master side for lbpkit, non-blocking, and the
// slave side kept open (so the master never sees a hang-up between clients)
// and set to a raw 8N1 binary line, as LBP is carried (manual: LBP, FRAMING).
#pragma once

#include <cstdint>
#include <string>

#include <stdexcept>

namespace lbpkit::server {

// A system call's failure: `what`, and errno's text.
std::runtime_error systemError(const std::string& what);

class PtyPair {
 public:
  // `baud` sets the slave's line speed, for a client that asks; a pty
  // carries bytes at any speed. A rate termios cannot name leaves 115200.
  explicit PtyPair(std::uint32_t baud);
  ~PtyPair();
  PtyPair(const PtyPair&) = delete;
  PtyPair& operator=(const PtyPair&) = delete;

  [[nodiscard]] int master() const { return master_; }
  [[nodiscard]] int slave() const { return slave_; }
  // The slave side: what a client opens.
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  int master_ = -1;
  int slave_ = -1;
  std::string path_;
};

}  // namespace lbpkit::server
