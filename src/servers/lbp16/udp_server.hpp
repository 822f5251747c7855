// A UDP socket serving datagrams one at a time from fixed buffers.
#pragma once

#include <netinet/in.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <span>
#include <string>

namespace net {

class UdpServer {
 public:
  static constexpr std::size_t kBuffer = 2048;  // room for anything up to an oversized frame

  // Binds ADDRESS:PORT (throws std::runtime_error saying why not).
  UdpServer(const std::string& address, std::uint16_t port);
  ~UdpServer();
  UdpServer(const UdpServer&) = delete;
  UdpServer& operator=(const UdpServer&) = delete;

  [[nodiscard]] std::uint16_t port() const { return port_; }
  [[nodiscard]] const std::string& address() const { return address_; }

  // How long ago the kernel received the last datagram served (its
  // SO_TIMESTAMPNS receive timestamp), so server-time figures include the
  // time a datagram queued in the socket, not only our handling of it. Falls
  // back to the moment we read it where the kernel gave no timestamp.
  [[nodiscard]] std::chrono::nanoseconds sinceReceived() const;
  // Of that, how long it waited in the socket before we read it.
  [[nodiscard]] std::chrono::nanoseconds lastQueueing() const { return queued_; }

  // Waits up to `timeout` for one datagram and answers it with what
  // `handler(request, reply)` returns (nothing when it returns 0). The one
  // blocking call of the per-packet path; no allocation.
  template <typename Handler>
  bool serveOnce(std::chrono::milliseconds timeout, Handler&& handler) {
    const auto n = receive(timeout);
    if (n < 0) return false;
    const std::size_t len = handler(std::span<const std::uint8_t>(in_.data(), static_cast<std::size_t>(n)),
                                    std::span<std::uint8_t>(out_.data(), out_.size()));
    if (len > 0) send(len);
    return true;
  }

 private:
  long receive(std::chrono::milliseconds timeout);
  void send(std::size_t len);

  int fd_ = -1;
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

}  // namespace net
