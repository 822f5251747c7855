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

namespace net {

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

long UdpServer::receive(std::chrono::milliseconds timeout) {
  pollfd p{fd_, POLLIN, 0};
  if (::poll(&p, 1, static_cast<int>(timeout.count())) <= 0) return -1;
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
  const ssize_t n = ::recvmsg(fd_, &msg, MSG_TRUNC);
  if (n < 0) return -1;
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
  if (static_cast<std::size_t>(n) > in_.size()) return static_cast<long>(in_.size());
  return static_cast<long>(n);
}

std::chrono::nanoseconds UdpServer::sinceReceived() const {
  timespec now{};
  ::clock_gettime(CLOCK_REALTIME, &now);
  const std::int64_t ns = now.tv_sec * 1'000'000'000LL + now.tv_nsec - receivedNs_;
  return std::chrono::nanoseconds(ns > 0 ? ns : 0);
}

void UdpServer::send(std::size_t len) {
  ::sendto(fd_, out_.data(), len, MSG_DONTWAIT, reinterpret_cast<sockaddr*>(&peer_), sizeof peer_);
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

}  // namespace net
