#include "lbpkit/lbp16_transport.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <thread>

#include "lbpkit/error.hpp"
#include "lbpkit/wire/lbp16.hpp"

namespace lbpkit {

Lbp16Transport::Lbp16Transport(const std::string& address, std::uint16_t port, Nanoseconds timeout)
    : address_(address), port_(port), timeout_(timeout), start_(std::chrono::steady_clock::now()) {
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(port);
  if (::inet_pton(AF_INET, address.c_str(), &sa.sin_addr) != 1)
    throw Error(fmt::format("--addr: \"{}\" is not an IPv4 address", address));
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0) throw Error(fmt::format("cannot create a UDP socket: {}", std::strerror(errno)));
  // Connected: only the card's replies (from ADDRESS:27181) get through.
  if (::connect(fd_, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd_);
    throw Error(fmt::format("cannot reach {}:{}: {}", address, port, why));
  }
}

Lbp16Transport::~Lbp16Transport() {
  if (fd_ >= 0) ::close(fd_);
}

std::string Lbp16Transport::describe() const { return fmt::format("LBP16 at {}:{}", address_, port_); }

Nanoseconds Lbp16Transport::now() { return std::chrono::steady_clock::now() - start_; }

void Lbp16Transport::sleep(Nanoseconds d) {
  // Short waits spin: a DOIT takes tens of microseconds, less than a timer slack.
  const auto until = std::chrono::steady_clock::now() + d;
  if (d > std::chrono::microseconds(200)) std::this_thread::sleep_for(d - std::chrono::microseconds(100));
  while (std::chrono::steady_clock::now() < until) {
  }
}

void Lbp16Transport::queueRead(std::uint16_t address, std::uint32_t* into, std::size_t count) {
  while (count > 0) {
    const std::size_t n = std::min<std::size_t>(count, 127);
    if (outLen_ + 4 > out_.size() || replyLen_ + 4 * n > out_.size() || readCount_ == reads_.size()) flush();
    const std::uint16_t cmd = wire::lbp16::hm2Read(static_cast<unsigned>(n));
    const std::uint8_t hdr[4] = {static_cast<std::uint8_t>(cmd), static_cast<std::uint8_t>(cmd >> 8),
                                 static_cast<std::uint8_t>(address), static_cast<std::uint8_t>(address >> 8)};
    std::memcpy(&out_[outLen_], hdr, 4);
    outLen_ += 4;
    reads_[readCount_++] = PendingRead{into, n};
    replyLen_ += 4 * n;
    into += n;
    count -= n;
    address = static_cast<std::uint16_t>(address + 4 * n);
  }
}

void Lbp16Transport::queueWrite(std::uint16_t address, const std::uint32_t* from, std::size_t count) {
  while (count > 0) {
    std::size_t n = std::min<std::size_t>(count, 127);
    if (outLen_ + 4 + 4 * n > out_.size()) flush();
    n = std::min(n, (out_.size() - 4) / 4);
    const std::uint16_t cmd = wire::lbp16::hm2Write(static_cast<unsigned>(n));
    const std::uint8_t hdr[4] = {static_cast<std::uint8_t>(cmd), static_cast<std::uint8_t>(cmd >> 8),
                                 static_cast<std::uint8_t>(address), static_cast<std::uint8_t>(address >> 8)};
    std::memcpy(&out_[outLen_], hdr, 4);
    outLen_ += 4;
    for (std::size_t i = 0; i < n; ++i)
      for (int b = 0; b < 4; ++b) out_[outLen_++] = static_cast<std::uint8_t>(from[i] >> (8 * b));
    from += n;
    count -= n;
    address = static_cast<std::uint16_t>(address + 4 * n);
  }
}

void Lbp16Transport::flush() {
  if (outLen_ == 0) return;
  sendAndReceive();
}

void Lbp16Transport::sendAndReceive() {
  // Leftovers of an exchange that timed out would be taken for this reply.
  while (::recv(fd_, in_.data(), in_.size(), MSG_DONTWAIT) > 0) {
  }
  if (::send(fd_, out_.data(), outLen_, 0) != static_cast<ssize_t>(outLen_))
    throw Error(fmt::format("{}: send failed: {}", describe(), std::strerror(errno)));
  ++exchanges_;
  const std::size_t expect = replyLen_;
  outLen_ = 0;
  replyLen_ = 0;
  const std::size_t reads = readCount_;
  readCount_ = 0;
  if (expect == 0) return;  // writes only: no reply
  const auto deadline = std::chrono::steady_clock::now() + timeout_;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    pollfd p{fd_, POLLIN, 0};
    if (left.count() < 0 || ::poll(&p, 1, static_cast<int>(std::max<long>(left.count(), 1))) <= 0)
      throw Error(fmt::format("no answer from {} within {} ms: is the card powered and on this network, and is "
                              "nothing else using it?",
                              describe(), std::chrono::duration_cast<std::chrono::milliseconds>(timeout_).count()));
    const ssize_t n = ::recv(fd_, in_.data(), in_.size(), 0);
    if (n < 0) {
      if (errno == ECONNREFUSED)
        throw Error(fmt::format("{} refused the datagram: nothing listens on UDP port {} there", describe(), port_));
      continue;
    }
    if (static_cast<std::size_t>(n) != expect) continue;  // a stray datagram: not ours
    break;
  }
  std::size_t at = 0;
  for (std::size_t r = 0; r < reads; ++r)
    for (std::size_t i = 0; i < reads_[r].count; ++i, at += 4)
      reads_[r].into[i] = std::uint32_t{in_[at]} | (std::uint32_t{in_[at + 1]} << 8) |
                          (std::uint32_t{in_[at + 2]} << 16) | (std::uint32_t{in_[at + 3]} << 24);
}

std::vector<std::uint8_t> Lbp16Transport::request(std::span<const std::uint8_t> datagram, std::size_t replyBytes) {
  flush();
  std::memcpy(out_.data(), datagram.data(), std::min(datagram.size(), out_.size()));
  outLen_ = std::min(datagram.size(), out_.size());
  replyLen_ = replyBytes;
  readCount_ = 0;
  sendAndReceive();
  return std::vector<std::uint8_t>(in_.begin(), in_.begin() + static_cast<std::ptrdiff_t>(replyBytes));
}

std::string Lbp16Transport::boardName() {
  const std::uint16_t cmd = wire::lbp16::Command{false, true, false, 7, 2, true, 8}.encode();
  const std::uint8_t req[4] = {static_cast<std::uint8_t>(cmd), static_cast<std::uint8_t>(cmd >> 8), 0, 0};
  const auto r = request(req, 16);
  std::string s;
  for (auto c : r)
    if (c) s.push_back(static_cast<char>(c));
  return s;
}

}  // namespace lbpkit
