// SPDX-License-Identifier: MIT
#include "lbpkit/lbp16_transport.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>
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

namespace {
// The sequence tag: one 16-bit scratch word in the LBP16 timer space, the one
// hm2_eth checks its reads with (docs/protocol-facts.md#lbp16-clients). Written, then read back as
// the datagram's last read.
constexpr std::uint16_t kTagAddress = wire::lbp16::timer::kScratch;
constexpr std::size_t kTagRequestBytes = 6 + 4;  // write: command, address, data; read: command, address
constexpr std::size_t kTagReplyBytes = 2;

void put16(std::uint8_t* p, std::uint16_t v) {
  p[0] = static_cast<std::uint8_t>(v);
  p[1] = static_cast<std::uint8_t>(v >> 8);
}
}  // namespace

void Lbp16Transport::queueRead(std::uint16_t address, std::uint32_t* into, std::size_t count) {
  while (count > 0) {
    const std::size_t n = std::min<std::size_t>(count, 127);
    if (outLen_ + 4 + kTagRequestBytes > out_.size() || replyLen_ + 4 * n + kTagReplyBytes > out_.size() ||
        readCount_ == reads_.size())
      sendFull();
    const std::uint16_t cmd = wire::lbp16::hm2Read(static_cast<unsigned>(n));
    put16(&out_[outLen_], cmd);
    put16(&out_[outLen_ + 2], address);
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
    if (outLen_ + 4 + 4 * n + kTagRequestBytes > out_.size()) sendFull();
    n = std::min(n, (out_.size() - 4 - kTagRequestBytes) / 4);
    const std::uint16_t cmd = wire::lbp16::hm2Write(static_cast<unsigned>(n));
    put16(&out_[outLen_], cmd);
    put16(&out_[outLen_ + 2], address);
    outLen_ += 4;
    for (std::size_t i = 0; i < n; ++i)
      for (int b = 0; b < 4; ++b) out_[outLen_++] = static_cast<std::uint8_t>(from[i] >> (8 * b));
    from += n;
    count -= n;
    address = static_cast<std::uint16_t>(address + 4 * n);
  }
}

void Lbp16Transport::sendFull() {
  // The queue cannot say whether it is filled by set-up or by a cycle; the
  // last explicit flush can (a cycle flushes with tryFlush() every time).
  const Nanoseconds timeout = cycleMode_ ? cycleTimeout_ : timeout_;
  const Outcome o = exchange(timeout, true);
  if (o != Outcome::Ok && pending_ == Outcome::Ok) {
    pending_ = o;
    pendingTimeout_ = timeout;
  }
}

void Lbp16Transport::flush() {
  cycleMode_ = false;
  Outcome o = pending_;
  Nanoseconds timeout = pendingTimeout_;
  pending_ = Outcome::Ok;
  if (outLen_ > 0) {
    const Outcome last = exchange(timeout_, true);
    if (o == Outcome::Ok) {
      o = last;
      timeout = timeout_;
    }
  }
  if (o != Outcome::Ok) throwFor(o, timeout);
}

bool Lbp16Transport::tryFlush() {
  cycleMode_ = true;
  bool ok = pending_ == Outcome::Ok;
  pending_ = Outcome::Ok;
  if (outLen_ > 0 && exchange(cycleTimeout_, true) != Outcome::Ok) ok = false;
  return ok;
}

void Lbp16Transport::throwFor(Outcome o, Nanoseconds timeout) const {
  switch (o) {
    case Outcome::Refused:
      throw Error(fmt::format("{} refused the datagram: nothing listens on UDP port {} there", describe(), port_));
    case Outcome::SendFailed:
      throw Error(fmt::format("{}: send failed: {}", describe(), std::strerror(errno_)));
    default:
      throw Error(fmt::format("no answer from {} within {} ms: is the card powered and on this network, and is "
                              "nothing else using it?",
                              describe(), std::chrono::duration<double, std::milli>(timeout).count()));
  }
}

Lbp16Transport::Outcome Lbp16Transport::exchange(Nanoseconds timeout, bool tagged) {
  // Whatever waits in the socket now cannot answer this request: a reply
  // that came after its exchange had timed out, or a stray datagram.
  for (;;) {
    if (::recv(fd_, in_.data(), in_.size(), MSG_DONTWAIT) >= 0) {
      ++counters_.discarded;
      continue;
    }
    if (errno != EINTR) break;  // empty (or an earlier ICMP error, now consumed)
  }
  std::size_t expect = replyLen_;
  const std::size_t reads = readCount_;
  const std::size_t len = outLen_;
  outLen_ = 0;
  replyLen_ = 0;
  readCount_ = 0;
  const std::uint16_t tag = ++sequence_;
  const bool withTag = tagged && expect > 0;
  std::size_t at = len;
  if (withTag) {
    // Room was kept for these by the queue functions.
    constexpr auto timer = static_cast<std::uint8_t>(wire::lbp16::Space::Timer);
    put16(&out_[at], wire::lbp16::Command{true, true, false, timer, 2, false, 1}.encode());
    put16(&out_[at + 2], kTagAddress);
    put16(&out_[at + 4], tag);
    put16(&out_[at + 6], wire::lbp16::Command{false, true, false, timer, 2, false, 1}.encode());
    put16(&out_[at + 8], kTagAddress);
    at += kTagRequestBytes;
    expect += kTagReplyBytes;
  }
  ssize_t sent = 0;
  do sent = ::send(fd_, out_.data(), at, 0);
  while (sent < 0 && errno == EINTR);
  if (sent != static_cast<ssize_t>(at)) {
    errno_ = sent < 0 ? errno : EMSGSIZE;
    ++counters_.sendFailures;
    return errno_ == ECONNREFUSED ? Outcome::Refused : Outcome::SendFailed;
  }
  ++exchanges_;
  if (expect == 0) return Outcome::Ok;  // writes only: no reply
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto left = std::chrono::duration_cast<Nanoseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      ++counters_.lostReplies;
      return Outcome::Lost;
    }
    // ppoll: a cycle's timeout may be well under the millisecond poll() counts in.
    const timespec ts{static_cast<time_t>(left.count() / 1'000'000'000),
                      static_cast<long>(left.count() % 1'000'000'000)};
    pollfd p{fd_, POLLIN, 0};
    if (::ppoll(&p, 1, &ts, nullptr) <= 0) continue;  // timed out or interrupted: the deadline decides
    const ssize_t n = ::recv(fd_, in_.data(), in_.size(), MSG_DONTWAIT);
    if (n < 0) {
      if (errno == ECONNREFUSED) {
        errno_ = ECONNREFUSED;
        ++counters_.sendFailures;
        return Outcome::Refused;
      }
      continue;
    }
    const auto got = static_cast<std::size_t>(n);
    if (got != expect ||
        (withTag && (std::uint16_t{in_[got - 2]} | static_cast<std::uint16_t>(in_[got - 1] << 8)) != tag)) {
      ++counters_.discarded;  // late (an earlier exchange's tag) or not ours
      continue;
    }
    break;
  }
  std::size_t pos = 0;
  for (std::size_t r = 0; r < reads; ++r)
    for (std::size_t i = 0; i < reads_[r].count; ++i, pos += 4)
      reads_[r].into[i] = std::uint32_t{in_[pos]} | (std::uint32_t{in_[pos + 1]} << 8) |
                          (std::uint32_t{in_[pos + 2]} << 16) | (std::uint32_t{in_[pos + 3]} << 24);
  return Outcome::Ok;
}

std::vector<std::uint8_t> Lbp16Transport::request(std::span<const std::uint8_t> datagram, std::size_t replyBytes) {
  flush();
  outLen_ = std::min(datagram.size(), out_.size());
  std::memcpy(out_.data(), datagram.data(), outLen_);
  replyLen_ = std::min(replyBytes, in_.size());
  readCount_ = 0;
  if (const Outcome o = exchange(timeout_, false); o != Outcome::Ok) throwFor(o, timeout_);
  const auto got = static_cast<std::ptrdiff_t>(std::min(replyBytes, in_.size()));
  return std::vector<std::uint8_t>(in_.begin(), in_.begin() + got);
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
