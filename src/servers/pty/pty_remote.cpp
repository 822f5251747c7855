// SPDX-License-Identifier: MIT
#include "pty/pty_remote.hpp"

#include <sys/ioctl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include "daemon/pcap_recorder.hpp"
#include "pty/pty_pair.hpp"

namespace lbpkit::server {

// The line is raw 8N1 at 115200, the setup-mode rate Mesa's tools use.
PtyRemote::PtyRemote(model::remote::RemoteDevice& device) : device_(device) {}

PtyRemote::~PtyRemote() = default;

int PtyRemote::unread() const {
  int n = 0;
  if (::ioctl(pty_.slave(), FIONREAD, &n) != 0) return 0;
  return n;
}

void PtyRemote::discardUnread() {
  const int n = unread();
  if (n <= 0) return;
  ::tcflush(pty_.slave(), TCIFLUSH);
  bytesDropped_ += static_cast<std::uint64_t>(n);
}

void PtyRemote::send(std::span<const std::uint8_t> reply) {
  if (unread() + static_cast<int>(reply.size()) > kMaxUnread) {
    bytesDropped_ += reply.size();  // overrun: the client is not reading
    return;
  }
  std::size_t done = 0;
  while (done < reply.size()) {
    const ssize_t w = ::write(pty_.master(), reply.data() + done, reply.size() - done);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) break;  // EAGAIN: the line's buffer is full
    done += static_cast<std::size_t>(w);
  }
  bytesOut_ += done;
  if (trace_ && done > 0) trace_->lbp(PcapRecorder::nowNs(), true, reply.first(done));
  bytesDropped_ += reply.size() - done;
}

void PtyRemote::run(const std::atomic<bool>& stop) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  auto now = [&]() { return std::chrono::duration_cast<model::lbp::SimTime>(Clock::now() - start); };
  std::uint8_t buffer[512];
  auto lastInput = Clock::now();
  auto lastProgress = Clock::now();
  int lastUnread = 0;
  while (!stop.load()) {
    pollfd pfd{pty_.master(), POLLIN, 0};
    const int ready = ::poll(&pfd, 1, 5);
    if (ready < 0 && errno != EINTR) throw systemError("poll on " + pty_.path());
    const auto t = now();
    device_.advance(t);
    // Answers waiting with no reader taking any for kAbandonedAfter belong
    // to a client that is gone (or stuck): drop them.
    const int waiting = unread();
    if (waiting == 0 || waiting < lastUnread) lastProgress = Clock::now();
    lastUnread = waiting;
    if (waiting > 0 && Clock::now() - lastProgress > kAbandonedAfter) {
      discardUnread();
      lastUnread = 0;
    }
    if (ready <= 0 || !(pfd.revents & POLLIN)) continue;
    const ssize_t n = ::read(pty_.master(), buffer, sizeof buffer);
    if (n <= 0) continue;
    if (Clock::now() - lastInput > kAbandonedAfter) discardUnread();
    lastInput = Clock::now();
    bytesIn_ += static_cast<std::uint64_t>(n);
    if (trace_) trace_->lbp(PcapRecorder::nowNs(), false, std::span<const std::uint8_t>(buffer, static_cast<std::size_t>(n)));
    for (ssize_t i = 0; i < n && !stop.load(); ++i) send(device_.receive(buffer[i], t));
  }
}

}  // namespace lbpkit::server
