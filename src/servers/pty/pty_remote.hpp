// The serial face of a remote: a virtual 7I77 processor on a pseudo-terminal,
// for programs that talk LBP to a real board through a USB-RS422 adapter
// (Mesa's RPD/WPD/UFLBP do; manual: RPD, WPD, AND UFLBP).
//
// The only place where the remote's simulated time follows the wall clock.
// Characters that arrive in one read() came back to back; a pause between
// reads is an inter-character gap, and the parser's framing timeout applies.
#pragma once

#include <atomic>
#include <string>

#include "remote/remote_device.hpp"

namespace net {

class PtyRemote {
 public:
  explicit PtyRemote(remote::RemoteDevice& device);
  ~PtyRemote();
  PtyRemote(const PtyRemote&) = delete;
  PtyRemote& operator=(const PtyRemote&) = delete;

  // The slave side: what a client opens, like /dev/ttyUSB0.
  [[nodiscard]] const std::string& path() const { return path_; }

  // Serves until `stop` becomes true (checked at least every 10 ms).
  void run(const std::atomic<bool>& stop);

  [[nodiscard]] std::uint64_t bytesIn() const { return bytesIn_; }
  [[nodiscard]] std::uint64_t bytesOut() const { return bytesOut_; }

 private:
  remote::RemoteDevice& device_;
  int master_ = -1;
  int slave_ = -1;  // kept open so the master never sees a hang-up between clients
  std::string path_;
  std::uint64_t bytesIn_ = 0;
  std::uint64_t bytesOut_ = 0;
};

}  // namespace net
