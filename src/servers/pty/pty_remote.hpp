// SPDX-License-Identifier: MIT
// The serial face of a remote: a virtual 7I77 processor on a pseudo-terminal,
// for programs that talk LBP to a real board through a USB-RS422 adapter
// (Mesa's RPD/WPD/UFLBP do; manual: RPD, WPD, AND UFLBP).
//
// The only place where the remote's simulated time follows the wall clock.
// Characters that arrive in one read() came back to back; a pause between
// reads is an inter-character gap, and the parser's framing timeout applies.
//
// The server never blocks on its client. Answers a client does not read are
// dropped once more than kMaxUnread bytes wait for it (a USB-RS422 adapter
// whose host stops reading overruns and loses characters; it does not stop
// the board), and answers nobody has taken any of for kAbandonedAfter, or
// left unread when a client went quiet that long, are discarded (a real
// serial device's input buffer goes with its last close; ours stays open
// between clients, so the next program would read them as its own).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <span>
#include <string>

#include "pty/pty_pair.hpp"
#include "remote/remote_device.hpp"

namespace lbpkit::server {

class PcapRecorder;

class PtyRemote {
 public:
  explicit PtyRemote(model::remote::RemoteDevice& device);
  ~PtyRemote();
  PtyRemote(const PtyRemote&) = delete;
  PtyRemote& operator=(const PtyRemote&) = delete;

  // The slave side: what a client opens, like /dev/ttyUSB0.
  [[nodiscard]] const std::string& path() const { return pty_.path(); }

  // Every LBP byte in and out, with its time, to `trace` (`lbpkit remote
  // --pty --trace FILE.pcap`; daemon/pcap_recorder.hpp); nullptr: none.
  void setTrace(PcapRecorder* trace) { trace_ = trace; }

  // Serves until `stop` becomes true (checked at least every 10 ms).
  void run(const std::atomic<bool>& stop);

  [[nodiscard]] std::uint64_t bytesIn() const { return bytesIn_; }
  [[nodiscard]] std::uint64_t bytesOut() const { return bytesOut_; }
  // Answer bytes the client never read: dropped at the source or discarded.
  [[nodiscard]] std::uint64_t bytesDropped() const { return bytesDropped_; }

  static constexpr int kMaxUnread = 2048;
  static constexpr std::chrono::milliseconds kAbandonedAfter{200};

 private:
  model::remote::RemoteDevice& device_;
  PtyPair pty_{115200};
  std::uint64_t bytesIn_ = 0;
  std::uint64_t bytesOut_ = 0;
  std::uint64_t bytesDropped_ = 0;
  PcapRecorder* trace_ = nullptr;

  [[nodiscard]] int unread() const;  // answer bytes waiting for the client
  void discardUnread();
  void send(std::span<const std::uint8_t> reply);
};

}  // namespace lbpkit::server
