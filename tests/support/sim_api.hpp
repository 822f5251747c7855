// SPDX-License-Identifier: MIT
// `lbpkit sim` as its API and process tests talk to it: an address and
// files of the test's own, the control API over plain sockets (so a test
// can misbehave as a hostile client would, and what it sees is the API's
// own answer, byte for byte), LBP16 datagrams as hm2_eth and mesaflash send
// them, and lbpkit's host library cycling the card.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "lbpkit/hostmot2.hpp"
#include "lbpkit/lbp16_transport.hpp"
#include "lbpkit/sserial.hpp"
#include "lbpkit/wire/lbp16.hpp"
#include "support/sim_child.hpp"
#include "support/temp_dir.hpp"

namespace test_support::sim_api {

// A loopback address of this test's own: 127.93.P.n, P from the process id
// (ctest runs tests side by side), n per test.
inline std::string loopback(int n) { return "127.93." + std::to_string(::getpid() % 250) + "." + std::to_string(n); }

// Files of this test process's own (state files, recordings), in a folder
// that goes with the process.
inline std::string tempPath(const std::string& name) {
  static const TempDir folder("lbpkit-simapi");
  auto p = folder / name;
  std::filesystem::remove(p);
  return p;
}

// A TCP connection to the API, closed when it goes.
class Conn {
 public:
  Conn(const std::string& address, int port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_port = htons(static_cast<std::uint16_t>(port));
    ::inet_pton(AF_INET, address.c_str(), &sa.sin_addr);
    ok_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&sa), sizeof sa) == 0;
    const int on = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
  }
  ~Conn() {
    if (fd_ >= 0) ::close(fd_);
  }
  Conn(const Conn&) = delete;
  Conn& operator=(const Conn&) = delete;
  [[nodiscard]] bool ok() const { return ok_; }
  bool send(const std::string& s) {
    std::size_t at = 0;
    while (at < s.size()) {
      const ssize_t n = ::send(fd_, s.data() + at, s.size() - at, MSG_NOSIGNAL);
      if (n <= 0) return false;
      at += static_cast<std::size_t>(n);
    }
    return true;
  }
  // Everything until the server closes, or `limit`.
  std::string readAll(std::chrono::milliseconds limit) {
    using Clock = std::chrono::steady_clock;
    std::string out;
    const auto end = Clock::now() + limit;
    while (Clock::now() < end) {
      pollfd p{fd_, POLLIN, 0};
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count();
      if (::poll(&p, 1, static_cast<int>(std::max<long long>(left, 1))) <= 0) continue;
      char buf[65536];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) break;
      out.append(buf, static_cast<std::size_t>(n));
    }
    return out;
  }

 private:
  int fd_ = -1;
  bool ok_ = false;
};

struct Reply {
  int status = 0;  // 0: no answer
  nlohmann::json body;
  std::string raw;
  std::chrono::milliseconds took{0};
};

inline Reply parse(const std::string& raw) {
  Reply r;
  r.raw = raw;
  if (raw.rfind("HTTP/1.", 0) == 0 && raw.size() > 12) r.status = std::atoi(raw.c_str() + 9);
  const auto at = raw.find("\r\n\r\n");
  if (at != std::string::npos) r.body = nlohmann::json::parse(raw.substr(at + 4), nullptr, false);
  return r;
}

struct Request {
  std::string method = "GET";
  std::string path = "/api/state";
  std::string body;
  std::string contentType = "application/json";
  std::optional<std::string> host;  // default: the API's own address:port
  std::vector<std::string> headers;
};

inline Reply http(const std::string& address, int port, const Request& q,
                  std::chrono::milliseconds limit = std::chrono::milliseconds(3000)) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  Conn c(address, port);
  if (!c.ok()) return {};
  std::string s = q.method + " " + q.path + " HTTP/1.1\r\n";
  s += "Host: " + q.host.value_or(address + ":" + std::to_string(port)) + "\r\n";
  for (const auto& h : q.headers) s += h + "\r\n";
  if (q.method == "POST") {
    if (!q.contentType.empty()) s += "Content-Type: " + q.contentType + "\r\n";
    s += "Content-Length: " + std::to_string(q.body.size()) + "\r\n";
  }
  s += "Connection: close\r\n\r\n" + q.body;
  c.send(s);
  Reply r = parse(c.readAll(limit));
  r.took = std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - start);
  return r;
}

// `lbpkit sim` on ADDRESS (LBP16 and API on free ports), its own state,
// asked over a raw HTTP connection: what is tested is the API's own answer,
// byte for byte.
class Sim : public SimChild {
 public:
  using SimChild::SimChild;
  Reply get(const std::string& path = "/api/state", std::chrono::milliseconds limit = std::chrono::milliseconds(3000)) {
    Request q;
    q.path = path;
    return send(q, limit);
  }
  Reply post(const std::string& path, const nlohmann::json& body,
             std::chrono::milliseconds limit = std::chrono::milliseconds(3000)) {
    Request q;
    q.method = "POST";
    q.path = path;
    q.body = body.dump();
    return send(q, limit);
  }
  Reply send(const Request& q, std::chrono::milliseconds limit = std::chrono::milliseconds(3000)) {
    return http(address(), apiPort(), q, limit);
  }
};

// `lbpkit sim` on the port hm2_eth and mesaflash use (27181), on an address
// of this test's own, its API on 127.0.0.1.
inline SimOptions onLbp16Port(int n) { return {loopback(n), -1, "127.0.0.1", true, {}, {}}; }

// --- LBP16 datagrams, as hm2_eth and mesaflash send them

using Bytes = std::vector<std::uint8_t>;

inline void command(Bytes& d, lbpkit::wire::lbp16::Command c, std::uint16_t address) {
  c.hasAddress = true;
  const auto w = c.encode();
  d.insert(d.end(), {static_cast<std::uint8_t>(w), static_cast<std::uint8_t>(w >> 8),
                     static_cast<std::uint8_t>(address), static_cast<std::uint8_t>(address >> 8)});
}

inline void put16(Bytes& d, std::uint16_t v) {
  d.insert(d.end(), {static_cast<std::uint8_t>(v), static_cast<std::uint8_t>(v >> 8)});
}

inline void put32(Bytes& d, std::uint32_t v) {
  put16(d, static_cast<std::uint16_t>(v));
  put16(d, static_cast<std::uint16_t>(v >> 16));
}

// Sends `d` and returns the reply (empty when none came within 1 s).
inline Bytes exchange(const std::string& address, int port, const Bytes& d) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(static_cast<std::uint16_t>(port));
  ::inet_pton(AF_INET, address.c_str(), &sa.sin_addr);
  ::sendto(fd, d.data(), d.size(), 0, reinterpret_cast<sockaddr*>(&sa), sizeof sa);
  Bytes reply(1500);
  pollfd p{fd, POLLIN, 0};
  ssize_t n = -1;
  if (::poll(&p, 1, 1000) > 0) n = ::recv(fd, reply.data(), reply.size(), 0);
  ::close(fd);
  reply.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
  return reply;
}

// A cookie read at the end of a datagram: its reply says the card took the
// whole datagram.
inline void cookieRead(Bytes& d) { command(d, {false, true, false, 0, 4, true, 1}, 0x0100); }

// lbpkit's host library on a sim's card over UDP, both 7I77 channels
// discovered and in normal mode. What the tests look at is the card, not
// the reply time: on loopback a reply is never lost, only late (this runs
// beside other tests, and under ASan), so each cycle waits up to 500 ms.
struct HostOnSim {
  explicit HostOnSim(Sim& sim)
      : t(sim.address(), static_cast<std::uint16_t>(sim.udpPort())), info(slowCardInfo(t)), ss(t, info, channels()) {
    ss.discover(0x03);
    ss.startNormal();
  }
  static lbpkit::CardInfo slowCardInfo(lbpkit::Lbp16Transport& transport) {
    transport.setCycleTimeout(std::chrono::milliseconds(500));
    return lbpkit::readCardInfo(transport);
  }
  static lbpkit::SmartSerial::Options channels() {
    lbpkit::SmartSerial::Options o;
    o.channelMask = 0x03;
    return o;
  }
  lbpkit::Lbp16Transport t;
  lbpkit::CardInfo info;
  lbpkit::SmartSerial ss;
};

}  // namespace test_support::sim_api
