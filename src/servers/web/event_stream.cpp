// SPDX-License-Identifier: MIT
#include "event_stream.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>

namespace lbpkit::server::web {

namespace {

using Clock = std::chrono::steady_clock;

// The answer's head: no length (the stream ends when the connection does),
// never cached, and a page that loses it reconnects after a second.
const auto kHead = std::make_shared<const std::string>(
    "HTTP/1.1 200 OK\r\n"
    "Content-Type: text/event-stream\r\n"
    "Cache-Control: no-store\r\n"
    "X-Content-Type-Options: nosniff\r\n"
    "Connection: close\r\n"
    "\r\n"
    "retry: 1000\n\n");

}  // namespace

struct EventStream::Client {
  int fd = -1;
  // What it is being sent (shared by every page sent the same frame), and
  // how much of it has gone: at most one frame waits per page.
  std::shared_ptr<const std::string> out;
  std::size_t at = 0;
  Clock::time_point progress;  // last byte taken, or nothing left to take
  Clock::time_point since;     // connected
  explicit Client(int f) : fd(f), out(kHead), progress(Clock::now()), since(progress) {}
  ~Client() {
    if (fd >= 0) ::close(fd);
  }
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  // Sends what it can without waiting; false when the page has gone.
  bool flush(Clock::time_point now) {
    while (out) {
      const ssize_t n = ::send(fd, out->data() + at, out->size() - at, MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n > 0) {
        at += static_cast<std::size_t>(n);
        progress = now;
        if (at == out->size()) {
          out.reset();
          at = 0;
        }
      } else if (n < 0 && errno == EINTR) {
        continue;
      } else if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
        return true;
      } else {
        return false;
      }
    }
    progress = now;
    return true;
  }
};

EventStream::EventStream(EventStreamOptions options, Producer produce)
    : options_(options), produce_(std::move(produce)) {
  wakeFd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  thread_ = std::thread([this] { loop(); });
}

EventStream::~EventStream() {
  stopping_ = true;
  wake();
  if (thread_.joinable()) thread_.join();
  for (const int fd : arriving_) ::close(fd);
  if (wakeFd_ >= 0) ::close(wakeFd_);
}

void EventStream::wake() const {
  const std::uint64_t one = 1;
  [[maybe_unused]] const auto n = ::write(wakeFd_, &one, sizeof one);
}

void EventStream::adopt(int fd) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!stopping_) {
      arriving_.push_back(fd);
      fd = -1;
    }
  }
  if (fd >= 0) ::close(fd);
  wake();
}

EventStreamCounters EventStream::counters() const {
  return {clients_.load(), frames_.load(), sent_.load(), skipped_.load(), dropped_.load()};
}

void EventStream::loop() {
  std::vector<std::unique_ptr<Client>> clients;
  std::vector<pollfd> fds;
  auto next = Clock::now();
  while (!stopping_) {
    // New pages: a small kernel buffer each, so a stalled one holds little.
    {
      std::vector<int> arrived;
      {
        std::lock_guard<std::mutex> lock(mutex_);
        arrived.swap(arriving_);
      }
      for (const int fd : arrived) {
        ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK);
        ::setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &options_.sendBuffer, sizeof options_.sendBuffer);
        if (clients.size() >= std::max(1U, options_.maxClients))
          clients.erase(std::min_element(clients.begin(), clients.end(),
                                         [](const auto& a, const auto& b) { return a->since < b->since; }));
        if (clients.empty()) next = Clock::now();  // the first page gets a frame at once
        clients.push_back(std::make_unique<Client>(fd));
        clients.back()->flush(Clock::now());  // the head, so the first frame finds it gone
      }
    }
    auto now = Clock::now();
    // A frame when one is due: made once, shared by every page free to take it.
    if (now >= next) {
      next += options_.period;
      if (next < now) next = now + options_.period;  // the producer took longer than a period
      if (!clients.empty()) {
        std::shared_ptr<const std::string> frame;
        try {
          auto data = produce_(counters());
          frame = std::make_shared<const std::string>("data: " + data + "\n\n");
          ++frames_;
        } catch (const std::exception&) {
          // The card thread is busy or the sim is stopping: no frame this time.
        }
        now = Clock::now();
        if (frame) {
          for (auto& c : clients) {
            if (c->out) {
              ++skipped_;
              continue;
            }
            c->out = frame;
            c->at = 0;
            c->progress = now;
            ++sent_;
          }
        }
      }
    }
    // Send what each page takes; drop the gone and the stalled.
    for (auto& c : clients) {
      if (!c->flush(now)) {
        c.reset();
      } else if (c->out && now - c->progress > options_.stallTimeout) {
        ++dropped_;
        c.reset();
      }
    }
    std::erase(clients, nullptr);
    clients_ = clients.size();

    fds.clear();
    fds.push_back({wakeFd_, POLLIN, 0});
    for (auto& c : clients)
      fds.push_back({c->fd, static_cast<short>(POLLIN | (c->out ? POLLOUT : 0)), 0});
    // Without pages, only an adoption (or stopping) wakes the thread.
    const auto wait = clients.empty()
                          ? 1000
                          : std::chrono::duration_cast<std::chrono::milliseconds>(next - Clock::now()).count() + 1;
    if (::poll(fds.data(), fds.size(), static_cast<int>(std::clamp<long long>(wait, 0, 1000))) < 0) continue;
    if (fds[0].revents & POLLIN) {
      std::uint64_t count = 0;
      [[maybe_unused]] const auto n = ::read(wakeFd_, &count, sizeof count);
    }
    // A page says nothing after its request: what it sends is read and
    // ignored, and its end (or an error) closes it.
    for (std::size_t i = 1; i < fds.size(); ++i) {
      if (!(fds[i].revents & (POLLIN | POLLERR | POLLHUP))) continue;
      char buf[1024];
      const ssize_t n = ::recv(fds[i].fd, buf, sizeof buf, MSG_DONTWAIT);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) clients[i - 1].reset();
    }
    std::erase(clients, nullptr);
    clients_ = clients.size();
  }
}

}  // namespace lbpkit::server::web
