// SPDX-License-Identifier: MIT
#include "lbp16/udp_server.hpp"

#include <arpa/inet.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <poll.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace lbpkit::server {

UdpServer::UdpServer(const std::string& address, std::uint16_t port) : address_(address) {
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(port);
  if (::inet_pton(AF_INET, address.c_str(), &sa.sin_addr) != 1)
    throw std::runtime_error("\"" + address + "\" is not an IPv4 address");
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw std::runtime_error(std::string("cannot create a UDP socket: ") + std::strerror(errno));
  if (::bind(fd_, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd_);
    throw std::runtime_error("cannot listen on " + address + ":" + std::to_string(port) + ": " + why +
                             " (is another card there, or is the address not on this machine?)");
  }
  // Kernel receive timestamps (CLOCK_REALTIME, ns) for honest server-time
  // figures; without them only our own handling would be measured.
  const int on = 1;
  ::setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on);
  socklen_t len = sizeof sa;
  ::getsockname(fd_, reinterpret_cast<sockaddr*>(&sa), &len);
  port_ = ntohs(sa.sin_port);
}

UdpServer::~UdpServer() {
  if (fd_ >= 0) ::close(fd_);
}

void UdpServer::alsoWakeOn(int fd) {
  for (int& w : wakers_)
    if (w < 0) {
      w = fd;
      return;
    }
  throw std::logic_error("UdpServer::alsoWakeOn: more than kWakers descriptors");
}

long UdpServer::receive(std::chrono::nanoseconds timeout) {
  std::array<pollfd, 1 + kWakers> p{};
  nfds_t n = 0;
  p[n++] = {fd_, POLLIN, 0};
  for (const int w : wakers_)
    if (w >= 0) p[n++] = {w, POLLIN, 0};
  // ppoll: a delayed datagram's time is kept to the microsecond, not
  // rounded up to poll()'s millisecond.
  // No wait at all (a caller that polled already): straight to the read,
  // which finds nothing or the datagram, one system call fewer.
  const auto ns = std::max<std::int64_t>(timeout.count(), 0);
  const timespec ts{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
  if (ns > 0 && (::ppoll(p.data(), n, &ts, nullptr) <= 0 || (p[0].revents & POLLIN) == 0)) return -1;
  // MSG_TRUNC gives the datagram's real length; one bigger than the buffer
  // is passed on as a full buffer, which the handler refuses as oversized.
  iovec iov{in_.data(), in_.size()};
  alignas(cmsghdr) std::uint8_t control[CMSG_SPACE(sizeof(timespec))];
  msghdr msg{};
  msg.msg_name = &peer_;
  msg.msg_namelen = sizeof peer_;
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  const ssize_t got = ::recvmsg(fd_, &msg, MSG_TRUNC | MSG_DONTWAIT);
  if (got < 0) return -1;
  timespec now{};
  ::clock_gettime(CLOCK_REALTIME, &now);
  const std::int64_t readNs = now.tv_sec * 1'000'000'000LL + now.tv_nsec;
  receivedNs_ = readNs;
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level != SOL_SOCKET || c->cmsg_type != SCM_TIMESTAMPNS) continue;
    timespec stamp{};
    std::memcpy(&stamp, CMSG_DATA(c), sizeof stamp);
    receivedNs_ = stamp.tv_sec * 1'000'000'000LL + stamp.tv_nsec;
  }
  queued_ = std::chrono::nanoseconds(readNs > receivedNs_ ? readNs - receivedNs_ : 0);
  if (static_cast<std::size_t>(got) > in_.size()) return static_cast<long>(in_.size());
  return static_cast<long>(got);
}

std::chrono::nanoseconds UdpServer::sinceReceived() const {
  timespec now{};
  ::clock_gettime(CLOCK_REALTIME, &now);
  const std::int64_t ns = now.tv_sec * 1'000'000'000LL + now.tv_nsec - receivedNs_;
  return std::chrono::nanoseconds(ns > 0 ? ns : 0);
}

void UdpServer::send(std::size_t len) {
  if (::sendto(fd_, out_.data(), len, MSG_DONTWAIT, reinterpret_cast<sockaddr*>(&peer_), sizeof peer_) < 0)
    ++sendFailures_;
}

void UdpServer::reply(std::size_t len) {
  const auto fate = faults_.decide(NetworkFaults::Kind::Reply, len, NetworkFaults::Clock::now());
  if (fate.lost) return;
  if (fate.corruptAt >= 0) NetworkFaults::damage(out_[static_cast<std::size_t>(fate.corruptAt)]);
  if (fate.delay.count() > 0 || fate.holdBehindNext) {
    // A reply held back behind this one has been overtaken all the same.
    releaseBehindNext(NetworkFaults::Kind::Reply);
    sendDueReplies(NetworkFaults::Clock::now());
    for (unsigned k = 0; k < fate.copies; ++k) hold(NetworkFaults::Kind::Reply, {out_.data(), len}, fate);
    return;
  }
  for (unsigned k = 0; k < fate.copies; ++k) send(len);
  releaseBehindNext(NetworkFaults::Kind::Reply);
  sendDueReplies(NetworkFaults::Clock::now());
}

void UdpServer::hold(NetworkFaults::Kind kind, std::span<const std::uint8_t> bytes, const NetworkFaults::Fate& fate) {
  for (auto& h : held_) {
    if (h.used) continue;
    h.used = true;
    h.kind = kind;
    h.behindNext = fate.holdBehindNext;
    h.due = NetworkFaults::Clock::now() + fate.delay;
    h.order = heldOrder_++;
    h.peer = peer_;
    h.size = std::min(bytes.size(), h.bytes.size());
    std::copy_n(bytes.begin(), h.size, h.bytes.begin());
    ++heldCount_;
    return;
  }
  faults_.countOverflow(kind);
}

void UdpServer::releaseBehindNext(NetworkFaults::Kind kind) {
  // The one behind has now been overtaken: it goes when its delay is up.
  for (auto& h : held_)
    if (h.used && h.kind == kind && h.behindNext) h.behindNext = false;
}

void UdpServer::sendDueReplies(NetworkFaults::Clock::time_point now) {
  while (heldCount_ > 0) {
    Held* next = nullptr;
    for (auto& h : held_)
      if (h.used && h.kind == NetworkFaults::Kind::Reply && !h.behindNext && h.due <= now &&
          (next == nullptr || h.order < next->order))
        next = &h;
    if (next == nullptr) return;
    if (::sendto(fd_, next->bytes.data(), next->size, MSG_DONTWAIT, reinterpret_cast<sockaddr*>(&next->peer),
                 sizeof next->peer) < 0)
      ++sendFailures_;
    next->used = false;
    --heldCount_;
  }
}

long UdpServer::takeDueRequest(NetworkFaults::Clock::time_point now) {
  Held* next = nullptr;
  for (auto& h : held_)
    if (h.used && h.kind == NetworkFaults::Kind::Request && !h.behindNext && h.due <= now &&
        (next == nullptr || h.order < next->order))
      next = &h;
  if (next == nullptr) return -1;
  std::copy_n(next->bytes.begin(), next->size, in_.begin());
  peer_ = next->peer;
  // The card receives it now: the time it was held is the network's.
  timespec t{};
  ::clock_gettime(CLOCK_REALTIME, &t);
  receivedNs_ = t.tv_sec * 1'000'000'000LL + t.tv_nsec;
  queued_ = std::chrono::nanoseconds{0};
  next->used = false;
  --heldCount_;
  return static_cast<long>(next->size);
}

std::chrono::nanoseconds UdpServer::untilNextDue(NetworkFaults::Clock::time_point now) const {
  auto soonest = std::chrono::nanoseconds::max();
  for (const auto& h : held_)
    if (h.used && !h.behindNext) soonest = std::min<std::chrono::nanoseconds>(soonest, std::max(h.due - now, {}));
  return soonest;
}

bool interfaceMac(const std::string& ipv4, std::array<std::uint8_t, 6>& mac, std::string& interface) {
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return false;
  bool found = false;
  for (ifaddrs* i = list; i; i = i->ifa_next) {
    if (!i->ifa_addr || i->ifa_addr->sa_family != AF_INET) continue;
    char text[INET_ADDRSTRLEN] = {};
    ::inet_ntop(AF_INET, &reinterpret_cast<sockaddr_in*>(i->ifa_addr)->sin_addr, text, sizeof text);
    if (ipv4 != text) continue;
    interface = i->ifa_name;
    if (i->ifa_flags & IFF_LOOPBACK) break;
    std::ifstream f("/sys/class/net/" + interface + "/address");
    std::string s;
    unsigned b[6];
    if (f >> s && std::sscanf(s.c_str(), "%x:%x:%x:%x:%x:%x", &b[0], &b[1], &b[2], &b[3], &b[4], &b[5]) == 6) {
      for (int k = 0; k < 6; ++k) mac[static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(b[k]);
      found = true;
    }
    break;
  }
  ::freeifaddrs(list);
  return found;
}

}  // namespace lbpkit::server
