// SPDX-License-Identifier: MIT
// A UDP socket serving datagrams one at a time from fixed buffers, through
// a network that may be made bad on purpose (network_faults.hpp).
#pragma once

#include <netinet/in.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <span>
#include <string>

#include "lbp16/network_faults.hpp"

namespace lbpkit::server {

class UdpServer {
 public:
  static constexpr std::size_t kBuffer = 2048;  // room for anything up to an oversized frame

  // Binds ADDRESS:PORT (throws std::runtime_error saying why not).
  UdpServer(const std::string& address, std::uint16_t port);
  ~UdpServer();
  UdpServer(const UdpServer&) = delete;
  UdpServer& operator=(const UdpServer&) = delete;

  [[nodiscard]] std::uint16_t port() const { return port_; }
  [[nodiscard]] int fd() const { return fd_; }
  // How long until a held datagram (network faults) is due; max() when
  // none is held.
  [[nodiscard]] std::chrono::nanoseconds untilDue(NetworkFaults::Clock::time_point now) const {
    return heldCount_ == 0 ? std::chrono::nanoseconds::max() : untilNextDue(now);
  }
  [[nodiscard]] const std::string& address() const { return address_; }

  // How long ago the kernel received the last datagram served (its
  // SO_TIMESTAMPNS receive timestamp), so server-time figures include the
  // time a datagram queued in the socket, not only our handling of it. Falls
  // back to the moment we read it where the kernel gave no timestamp.
  [[nodiscard]] std::chrono::nanoseconds sinceReceived() const;
  // Of that, how long it waited in the socket before we read it.
  [[nodiscard]] std::chrono::nanoseconds lastQueueing() const { return queued_; }
  // The datagram being served: who sent it, and when the kernel received it
  // (CLOCK_REALTIME ns), for `lbpkit sim --trace`.
  [[nodiscard]] const sockaddr_in& peer() const { return peer_; }
  [[nodiscard]] std::int64_t receivedNs() const { return receivedNs_; }

  // Waits up to `timeout` for one datagram and answers it with what
  // `handler(request, reply)` returns (nothing when it returns 0). The one
  // blocking call of the per-packet path; no allocation. Returns whether a
  // request reached the handler. With network faults set, a datagram may be
  // lost or held, and a held one is handled or sent when its time comes.
  template <typename Handler>
  bool serveOnce(std::chrono::milliseconds timeout, Handler&& handler) {
    const auto now = NetworkFaults::Clock::now();
    if (heldCount_ == 0 && !faults_.active(now)) {
      const auto n = receive(timeout);
      if (n < 0) return false;
      const std::size_t len = handler(std::span<const std::uint8_t>(in_.data(), static_cast<std::size_t>(n)),
                                      std::span<std::uint8_t>(out_.data(), out_.size()));
      if (len > 0) send(len);
      return true;
    }
    sendDueReplies(now);
    long n = takeDueRequest(now);
    if (n < 0) {
      n = receive(std::min<std::chrono::nanoseconds>(timeout, untilNextDue(now)));
      if (n < 0) {
        sendDueReplies(NetworkFaults::Clock::now());
        return false;
      }
      const std::span<const std::uint8_t> request(in_.data(), static_cast<std::size_t>(n));
      const auto fate = faults_.decide(NetworkFaults::Kind::Request, request.size(), NetworkFaults::Clock::now(),
                                       NetworkFaults::asksForReply(request));
      if (fate.lost) return false;
      if (fate.corruptAt >= 0) NetworkFaults::damage(in_[static_cast<std::size_t>(fate.corruptAt)]);
      if (fate.delay.count() > 0 || fate.holdBehindNext) {
        releaseBehindNext(NetworkFaults::Kind::Request);  // overtaken: it goes next
        hold(NetworkFaults::Kind::Request, {in_.data(), static_cast<std::size_t>(n)}, fate);
        return false;
      }
      copies_ = fate.copies;
    }
    for (unsigned k = 0; k < copies_; ++k) {
      const std::size_t len = handler(std::span<const std::uint8_t>(in_.data(), static_cast<std::size_t>(n)),
                                      std::span<std::uint8_t>(out_.data(), out_.size()));
      if (len > 0) reply(len);
    }
    copies_ = 1;
    releaseBehindNext(NetworkFaults::Kind::Request);
    return true;
  }

  // A descriptor (an eventfd) whose readiness also ends serveOnce()'s wait,
  // so a thread that sleeps until the next datagram still hears of other
  // work at once. Its owner clears it. At most kWakers.
  static constexpr std::size_t kWakers = 3;
  void alsoWakeOn(int fd);

  // The network between host and card (set on the serving thread only).
  NetworkFaults& faults() { return faults_; }
  [[nodiscard]] const NetworkFaults& faults() const { return faults_; }
  // Datagrams held back now (delayed or reordered).
  [[nodiscard]] unsigned held() const { return heldCount_; }
  // Replies the kernel refused to send (a full socket buffer, no route):
  // the card's TX error count (LBP16 space 6).
  [[nodiscard]] std::uint64_t sendFailures() const { return sendFailures_; }

 private:
  long receive(std::chrono::nanoseconds timeout);
  void send(std::size_t len);
  // The faulty path's pieces (network_faults.hpp): a reply through the
  // network, datagrams held and let go.
  void reply(std::size_t len);
  void hold(NetworkFaults::Kind kind, std::span<const std::uint8_t> bytes, const NetworkFaults::Fate& fate);
  void releaseBehindNext(NetworkFaults::Kind kind);
  void sendDueReplies(NetworkFaults::Clock::time_point now);
  long takeDueRequest(NetworkFaults::Clock::time_point now);
  [[nodiscard]] std::chrono::nanoseconds untilNextDue(NetworkFaults::Clock::time_point now) const;

  // A delayed or reordered datagram: 64 of them at most (beyond that the
  // network loses them, and says so), in buffers made once.
  static constexpr unsigned kHeld = 64;
  struct Held {
    bool used = false;
    NetworkFaults::Kind kind = NetworkFaults::Kind::Request;
    bool behindNext = false;  // waits for the next datagram of its kind, then is due at once
    NetworkFaults::Clock::time_point due{};
    std::uint64_t order = 0;  // held ones due together leave in the order they came
    sockaddr_in peer{};
    std::size_t size = 0;
    std::array<std::uint8_t, kBuffer> bytes{};
  };
  std::array<Held, kHeld> held_{};
  unsigned heldCount_ = 0;
  std::uint64_t heldOrder_ = 0;
  unsigned copies_ = 1;  // a duplicated request is handled twice
  std::uint64_t sendFailures_ = 0;
  NetworkFaults faults_;

  int fd_ = -1;
  std::array<int, kWakers> wakers_{-1, -1, -1};
  std::string address_;
  std::uint16_t port_ = 0;
  std::array<std::uint8_t, kBuffer> in_{};
  std::array<std::uint8_t, kBuffer> out_{};
  sockaddr_in peer_{};
  std::int64_t receivedNs_ = 0;  // CLOCK_REALTIME, as the kernel stamps
  std::chrono::nanoseconds queued_{0};
};

// The MAC address of the interface that has `ipv4` (none for loopback).
bool interfaceMac(const std::string& ipv4, std::array<std::uint8_t, 6>& mac, std::string& interface);

}  // namespace lbpkit::server
