// SPDX-License-Identifier: MIT
// The web view's event stream: server-sent events to every page
// that asked for them, a frame at a fixed rate, on a thread of its own.
//
// The card thread never waits on a page. A frame is made once per period
// whatever the number of pages (its producer takes one snapshot through the
// card thread's job queue, like GET /api/state), and each page gets it
// through a non-blocking socket with a small send buffer. A page that has
// not taken its last frame skips the new one (it gets the newest one when it
// catches up); one that takes nothing for `stallTimeout` is dropped. So each
// page costs at most one frame and one socket buffer, however slow it is.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace lbpkit::server::web {

struct EventStreamOptions {
  std::chrono::milliseconds period{40};  // 25 frames a second (at least 20)
  unsigned maxClients = 16;              // one more closes the oldest
  // A page that takes no byte of its frame for this long is dropped.
  std::chrono::milliseconds stallTimeout{3000};
  int sendBuffer = 64 * 1024;  // the kernel's buffer per page (SO_SNDBUF)
};

// What the stream has done, for the frames themselves and for tests.
struct EventStreamCounters {
  std::uint64_t clients = 0;  // connected now
  std::uint64_t frames = 0;   // made
  std::uint64_t sent = 0;     // handed to a page, whole or begun
  std::uint64_t skipped = 0;  // not sent to a page still busy with the one before
  std::uint64_t dropped = 0;  // pages closed for taking nothing for stallTimeout
};

class EventStream {
 public:
  // Makes a frame's data: one line of text (JSON), no newline in it. Called
  // on the stream's thread once per period while a page is connected;
  // whatever it throws skips that frame.
  using Producer = std::function<std::string(const EventStreamCounters&)>;

  EventStream(EventStreamOptions options, Producer produce);
  ~EventStream();
  EventStream(const EventStream&) = delete;
  EventStream& operator=(const EventStream&) = delete;

  // Takes over a connected socket whose request asked for the stream
  // (the API has checked it): the stream writes the answer's head, then
  // frames, and closes it.
  void adopt(int fd);
  [[nodiscard]] EventStreamCounters counters() const;

 private:
  struct Client;
  void loop();
  void wake() const;

  EventStreamOptions options_;
  Producer produce_;
  int wakeFd_ = -1;
  std::atomic<bool> stopping_{false};
  mutable std::mutex mutex_;
  std::vector<int> arriving_;  // adopted, not yet taken by the thread
  std::atomic<std::uint64_t> clients_{0}, frames_{0}, sent_{0}, skipped_{0}, dropped_{0};
  std::thread thread_;
};

}  // namespace lbpkit::server::web
