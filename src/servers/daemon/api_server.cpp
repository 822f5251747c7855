// SPDX-License-Identifier: MIT
// The control API's HTTP server: its own listening socket (no SO_REUSEPORT),
// one poller thread that holds every connection and reads until a request is
// whole (slow and idle clients cost it nothing but a socket, and meet the
// request, idle and size limits there), and worker threads that hand each
// whole request to httplib's router (api_routes.cpp) and write its answer.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>
#include <httplib.h>
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <string_view>
#include <thread>
#include <vector>

#include "daemon/api_http.hpp"
#include "daemon/api_routes.hpp"
#include "daemon/web_view.hpp"
#include "lbpkit/wire/names.hpp"

namespace lbpkit::server {

using nlohmann::json;

namespace {

using Clock = std::chrono::steady_clock;

// --- Connections

// httplib parses a request, routes it and writes the answer; process_request
// is protected, so this is how it is reached.
class HttpEngine : public httplib::Server {
 public:
  bool answer(httplib::Stream& s, bool closeAfter, bool& closed) { return process_request(s, closeAfter, closed, nullptr); }
};

struct Connection {
  int fd = -1;
  std::string in;  // bytes received and not yet answered
  Clock::time_point since;  // accepted, or last answer sent
  Clock::time_point started;  // first byte of the request now arriving
  Clock::time_point drainUntil;
  std::size_t requestBytes = 0;  // of `in`: the whole request handed to a worker
  unsigned served = 0;
  bool draining = false;  // answered and half closed: reading what still comes, then closing
  bool continued = false;  // sent "100 Continue" for this request
  bool adopted = false;  // its socket goes to the web view's event stream (web_view.hpp)
  std::string peer, local;
  int peerPort = 0, localPort = 0;
  ~Connection() {
    if (fd >= 0) ::close(fd);
  }
};

using ConnectionPtr = std::unique_ptr<Connection>;

// The connection a worker is answering: GET /api/events marks it adopted.
thread_local Connection* answeringNow = nullptr;

std::string addressOf(const sockaddr_in& sa, int& port) {
  char text[INET_ADDRSTRLEN] = {};
  ::inet_ntop(AF_INET, &sa.sin_addr, text, sizeof text);
  port = ntohs(sa.sin_port);
  return text;
}

// One whole request, read by the poller, as httplib reads it; the answer
// goes straight to the socket, within the write timeout from its first byte
// (the route may have waited for the card thread before).
class RequestStream final : public httplib::Stream {
 public:
  RequestStream(const Connection& c, std::chrono::milliseconds writeTimeout)
      : c_(c), request_(std::string_view(c.in).substr(0, c.requestBytes)), writeTimeout_(writeTimeout) {}
  bool is_readable() const override { return at_ < request_.size(); }
  bool is_writable() const override { return wait(POLLOUT); }
  ssize_t read(char* ptr, size_t size) override {
    const auto n = std::min(size, request_.size() - at_);
    std::memcpy(ptr, request_.data() + at_, n);
    at_ += n;
    return static_cast<ssize_t>(n);
  }
  ssize_t write(const char* ptr, size_t size) override {
    if (c_.adopted) return static_cast<ssize_t>(size);  // the event stream writes its own answer
    std::size_t done = 0;
    while (done < size) {
      const ssize_t n = ::send(c_.fd, ptr + done, size - done, MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n > 0) {
        done += static_cast<std::size_t>(n);
      } else if (n < 0 && errno == EINTR) {
        continue;
      } else if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
        if (!wait(POLLOUT)) return -1;
      } else {
        return -1;
      }
    }
    return static_cast<ssize_t>(size);
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override {
    ip = c_.peer;
    port = c_.peerPort;
  }
  void get_local_ip_and_port(std::string& ip, int& port) const override {
    ip = c_.local;
    port = c_.localPort;
  }
  socket_t socket() const override { return c_.fd; }

 private:
  bool wait(short events) const {
    if (deadline_ == Clock::time_point{}) deadline_ = Clock::now() + writeTimeout_;
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline_ - Clock::now()).count();
    if (left <= 0) return false;
    pollfd p{c_.fd, events, 0};
    return ::poll(&p, 1, static_cast<int>(left)) > 0 && (p.revents & events) && !(p.revents & (POLLERR | POLLHUP));
  }

  const Connection& c_;
  std::string_view request_;
  std::size_t at_ = 0;
  std::chrono::milliseconds writeTimeout_;
  mutable Clock::time_point deadline_{};  // set when writing first has to wait
};

// What the poller makes of the bytes a connection has sent so far.
enum class Verdict { Wait, Whole, Refused };

}  // namespace

struct ControlApi::Server {
  ApiOptions options;
  HttpEngine http;
  int listenFd = -1;
  int wakeFd = -1;
  std::atomic<bool> stopping{false};
  std::thread poller;
  std::vector<std::thread> workers;
  // Whole requests for the workers, connections back from them, and the
  // sockets they are answering on (shut down to stop them at once).
  std::mutex mutex;
  std::condition_variable ready;
  std::deque<ConnectionPtr> requests;
  std::vector<ConnectionPtr> returned;
  std::set<int> answering;
  std::atomic<unsigned> away{0};  // connections the poller has handed on
  std::unique_ptr<WebView> web;  // the page and its event stream; gone before the rest

  ~Server() {
    if (listenFd >= 0) ::close(listenFd);
    if (wakeFd >= 0) ::close(wakeFd);
  }
  void wake() const {
    const std::uint64_t one = 1;
    [[maybe_unused]] const auto n = ::write(wakeFd, &one, sizeof one);
  }
  void poll();
  void work();
  Verdict examine(Connection& c);
  void refuseAndClose(Connection& c, int status, const char* reason, const std::string& why);
};

void ControlApi::Server::refuseAndClose(Connection& c, int status, const char* reason, const std::string& why) {
  const auto content = json{{"error", why}}.dump();
  const auto text = fmt::format("HTTP/1.1 {} {}\r\nContent-Type: application/json\r\nContent-Length: {}\r\n"
                                "Connection: close\r\n\r\n{}",
                                status, reason, content.size(), content);
  // Small, on a socket with nothing else queued: it fits its buffer. Then
  // half close and read what the client still sends for a while, so the
  // answer reaches it instead of a reset.
  [[maybe_unused]] const auto n = ::send(c.fd, text.data(), text.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  ::shutdown(c.fd, SHUT_WR);
  c.draining = true;
  c.drainUntil = Clock::now() + std::chrono::seconds(1);
  c.in.clear();
}

Verdict ControlApi::Server::examine(Connection& c) {
  const auto end = c.in.find("\r\n\r\n");
  if (end == std::string::npos) {
    if (c.in.size() <= options.maxHeader) return Verdict::Wait;
    refuseAndClose(c, 431, "Request Header Fields Too Large",
                   fmt::format("the request line and headers are over {} bytes", options.maxHeader));
    return Verdict::Refused;
  }
  const std::size_t head = end + 4;
  if (head > options.maxHeader) {
    refuseAndClose(c, 431, "Request Header Fields Too Large",
                   fmt::format("the request line and headers are over {} bytes", options.maxHeader));
    return Verdict::Refused;
  }
  // The few headers that say how long the request is.
  std::size_t length = 0;
  bool expectContinue = false;
  std::size_t expectAt = std::string::npos;
  for (std::size_t at = c.in.find("\r\n") + 2; at < end;) {
    const auto eol = c.in.find("\r\n", at);
    const auto line = std::string_view(c.in).substr(at, eol - at);
    const auto colon = line.find(':');
    if (colon != std::string_view::npos) {
      const auto name = lbpkit::wire::asciiLower(std::string(line.substr(0, colon)));
      auto value = line.substr(colon + 1);
      while (!value.empty() && (value.front() == ' ' || value.front() == '\t')) value.remove_prefix(1);
      while (!value.empty() && (value.back() == ' ' || value.back() == '\t')) value.remove_suffix(1);
      if (name == "transfer-encoding") {
        refuseAndClose(c, 411, "Length Required",
                       fmt::format("send bodies with a Content-Length (at most {} bytes), not {}", options.maxBody,
                                   std::string(value)));
        return Verdict::Refused;
      }
      if (name == "content-length") {
        if (value.empty() || value.size() > 12 || value.find_first_not_of("0123456789") != std::string_view::npos) {
          refuseAndClose(c, 400, "Bad Request", "Content-Length is not a number");
          return Verdict::Refused;
        }
        length = std::stoull(std::string(value));
        if (length > options.maxBody) {
          refuseAndClose(c, 413, "Payload Too Large",
                         fmt::format("the body is too large: {} bytes, at most {}", length, options.maxBody));
          return Verdict::Refused;
        }
      }
      if (name == "expect" && lbpkit::wire::asciiLower(std::string(value)) == "100-continue") {
        expectContinue = true;
        expectAt = at;
      }
    }
    at = eol + 2;
  }
  if (c.in.size() >= head + length) {
    c.requestBytes = head + length;
    return Verdict::Whole;
  }
  if (expectContinue && !c.continued) {
    // The client waits for this before it sends the body. Said here, where
    // the body is waited for; the header is renamed (same length) so httplib
    // does not say it a second time.
    static constexpr char kContinue[] = "HTTP/1.1 100 Continue\r\n\r\n";
    [[maybe_unused]] const auto n = ::send(c.fd, kContinue, sizeof kContinue - 1, MSG_NOSIGNAL | MSG_DONTWAIT);
    c.in[expectAt] = 'X';
    c.continued = true;
  }
  return Verdict::Wait;
}

// The one thread that waits on clients: it accepts, reads requests until
// they are whole, enforces the timeouts and the connection cap, and hands
// whole requests to the workers. A slow or idle client costs a socket here,
// never a worker.
void ControlApi::Server::poll() {
  std::vector<ConnectionPtr> conns;
  std::vector<pollfd> fds;
  Clock::time_point acceptPausedUntil{};
  auto hand = [&](ConnectionPtr c) {
    ++away;
    {
      std::lock_guard<std::mutex> lock(mutex);
      requests.push_back(std::move(c));
    }
    ready.notify_one();
  };
  while (!stopping) {
    const auto now = Clock::now();
    {
      std::vector<ConnectionPtr> back;
      {
        std::lock_guard<std::mutex> lock(mutex);
        back.swap(returned);
      }
      for (auto& c : back) {
        --away;
        c->since = c->started = now;
        c->continued = false;
        // Pipelined bytes of the next request may already be here.
        if (!c->in.empty() && examine(*c) == Verdict::Whole)
          hand(std::move(c));
        else
          conns.push_back(std::move(c));
      }
    }
    // Deadlines: idle, a request too slow to arrive, draining done.
    auto next = now + std::chrono::seconds(1);
    for (auto& c : conns) {
      Clock::time_point due;
      if (c->draining)
        due = c->drainUntil;
      else if (!c->in.empty())
        due = c->started + options.requestTimeout;
      else
        due = c->since + options.idleTimeout;
      if (due <= now) {
        if (!c->draining && !c->in.empty()) {
          refuseAndClose(*c, 408, "Request Timeout",
                         fmt::format("the request did not arrive whole within {} ms", options.requestTimeout.count()));
          due = c->drainUntil;
        } else {
          c.reset();
          continue;
        }
      }
      next = std::min(next, due);
    }
    std::erase(conns, nullptr);

    fds.clear();
    fds.push_back({wakeFd, POLLIN, 0});
    const bool accepting = now >= acceptPausedUntil;
    fds.push_back({accepting ? listenFd : -1, POLLIN, 0});
    for (auto& c : conns) fds.push_back({c->fd, POLLIN, 0});
    const auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(next - now).count() + 1;
    if (::poll(fds.data(), fds.size(), static_cast<int>(std::clamp<long long>(wait, 0, 1000))) < 0) continue;
    if (stopping) break;
    if (fds[0].revents & POLLIN) {
      std::uint64_t count = 0;
      [[maybe_unused]] const auto n = ::read(wakeFd, &count, sizeof count);
    }
    // Reads first: a request that is whole goes before new connections can
    // push its connection out.
    for (std::size_t i = 2; i < fds.size(); ++i) {
      if (!fds[i].revents) continue;
      auto& c = conns[i - 2];
      char buf[16384];
      const ssize_t n = ::recv(c->fd, buf, sizeof buf, 0);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
        c.reset();
        continue;
      }
      if (n < 0 || c->draining) continue;
      if (c->in.empty()) c->started = Clock::now();
      c->in.append(buf, static_cast<std::size_t>(n));
      if (examine(*c) == Verdict::Whole) hand(std::move(c));
    }
    std::erase(conns, nullptr);
    if (accepting && (fds[1].revents & POLLIN)) {
      for (;;) {
        sockaddr_in peer{};
        socklen_t len = sizeof peer;
        const int fd = ::accept4(listenFd, reinterpret_cast<sockaddr*>(&peer), &len, SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (fd < 0) {
          // Out of descriptors: the connection stays queued; try again soon
          // instead of spinning on it.
          if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM)
            acceptPausedUntil = Clock::now() + std::chrono::milliseconds(100);
          break;
        }
        auto c = std::make_unique<Connection>();
        c->fd = fd;
        c->since = Clock::now();
        c->peer = addressOf(peer, c->peerPort);
        sockaddr_in local{};
        len = sizeof local;
        ::getsockname(fd, reinterpret_cast<sockaddr*>(&local), &len);
        c->local = addressOf(local, c->localPort);
        const int on = 1;
        ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
        // The cap: make room by closing the connection that has waited
        // longest on its client; when every one is being answered, this one
        // goes.
        if (conns.size() + away >= options.maxConnections) {
          if (conns.empty()) continue;  // c closes as it goes
          std::iter_swap(std::min_element(conns.begin(), conns.end(),
                                          [](const auto& a, const auto& b) { return a->since < b->since; }),
                         conns.end() - 1);
          conns.pop_back();
        }
        conns.push_back(std::move(c));
      }
    }
  }
  conns.clear();
}

// A worker: answers whole requests, then gives the connection back to the
// poller to wait for its next one.
void ControlApi::Server::work() {
  for (;;) {
    ConnectionPtr c;
    {
      std::unique_lock<std::mutex> lock(mutex);
      ready.wait(lock, [this] { return stopping || !requests.empty(); });
      if (stopping) return;
      c = std::move(requests.front());
      requests.pop_front();
      answering.insert(c->fd);
    }
    const bool last = ++c->served >= options.maxRequestsPerConnection;
    bool closed = false;
    bool ok = false;
    {
      RequestStream s(*c, options.writeTimeout);
      answeringNow = c.get();
      ok = http.answer(s, last, closed);
      answeringNow = nullptr;
    }
    {
      std::lock_guard<std::mutex> lock(mutex);
      answering.erase(c->fd);
      if (c->adopted) {
        --away;
        web->adopt(std::exchange(c->fd, -1));
      } else if (ok && !closed && !last && !stopping) {
        c->in.erase(0, c->requestBytes);
        c->requestBytes = 0;
        returned.push_back(std::move(c));
      } else {
        --away;
      }
    }
    wake();
  }
}

ControlApi::ControlApi(const ApiOptions& options, ApiTarget target, CardThreadRunner run)
    : server_(std::make_unique<Server>()) {
  auto& s = *server_;
  s.options = options;
  // The listening socket is ours, bound without SO_REUSEPORT (httplib sets
  // it): a second sim on the same port must fail, not share it and get
  // half the requests. SO_REUSEADDR only lets a restarted sim have its port
  // back while old connections linger.
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(static_cast<std::uint16_t>(options.port));
  if (::inet_pton(AF_INET, options.address.c_str(), &sa.sin_addr) != 1)
    throw std::runtime_error(fmt::format("control API: \"{}\" is not an IPv4 address", options.address));
  s.listenFd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  s.wakeFd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (s.listenFd < 0 || s.wakeFd < 0)
    throw std::runtime_error(fmt::format("control API: cannot create a socket: {}", std::strerror(errno)));
  const int on = 1;
  ::setsockopt(s.listenFd, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
  if (::bind(s.listenFd, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0) {
    if (errno == EADDRINUSE)
      throw std::runtime_error(fmt::format("control API port {}:{} is in use (another lbpkit sim?); --api 0 picks a "
                                           "free one",
                                           options.address, options.port));
    throw std::runtime_error(fmt::format("cannot serve the control API on {}:{}: {}", options.address, options.port,
                                         std::strerror(errno)));
  }
  if (::listen(s.listenFd, 128) != 0)
    throw std::runtime_error(fmt::format("cannot serve the control API on {}:{}: {}", options.address, options.port,
                                         std::strerror(errno)));
  socklen_t len = sizeof sa;
  ::getsockname(s.listenFd, reinterpret_cast<sockaddr*>(&sa), &len);
  port_ = ntohs(sa.sin_port);

  auto& http = s.http;
  http.set_payload_max_length(options.maxBody);
  http.set_keep_alive_max_count(options.maxRequestsPerConnection);  // what its Keep-Alive header says
  http.set_keep_alive_timeout(std::max<time_t>(1, static_cast<time_t>(options.idleTimeout.count() / 1000)));
  addApiRoutes(http, options, port_, target, run);
  s.web = std::make_unique<WebView>(target, run);
  s.web->addRoutes(http, [] {
    if (answeringNow != nullptr) answeringNow->adopted = true;
  });
  s.poller = std::thread([this] { server_->poll(); });
  for (unsigned i = 0; i < std::max(1U, options.workers); ++i) s.workers.emplace_back([this] { server_->work(); });
}

ControlApi::~ControlApi() {
  auto& s = *server_;
  {
    // Under the lock, so no worker takes a request after the sockets being
    // answered are shut down: a worker writing to a client that does not
    // read, or reading nothing, returns at once.
    std::lock_guard<std::mutex> lock(s.mutex);
    s.stopping = true;
    for (const int fd : s.answering) ::shutdown(fd, SHUT_RDWR);
  }
  s.ready.notify_all();
  s.wake();
  if (s.poller.joinable()) s.poller.join();
  for (auto& w : s.workers)
    if (w.joinable()) w.join();
}

}  // namespace lbpkit::server
