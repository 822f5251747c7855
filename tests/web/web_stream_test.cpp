// SPDX-License-Identifier: MIT
// The web view's event stream against pages that stop reading:
// the card's server time per datagram stays what it is without them
// (figures printed), the sim's memory does not grow, and the stalled pages
// are dropped while a page that reads keeps getting its frames.
#include <poll.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>

#include "web_support.hpp"

namespace {

using namespace std::chrono_literals;

using namespace webtest;

// A page's event stream over a plain socket: asks for it, then reads it
// (or, stalled, never does).
class StreamClient {
 public:
  StreamClient(const Sim& sim, int receiveBuffer = 0) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    // Before connecting, so the window the sim sees stays small.
    if (receiveBuffer > 0) ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &receiveBuffer, sizeof receiveBuffer);
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_port = htons(static_cast<std::uint16_t>(sim.apiPort()));
    ::inet_pton(AF_INET, sim.address().c_str(), &sa.sin_addr);
    ok_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&sa), sizeof sa) == 0;
    const std::string req = "GET /api/events HTTP/1.1\r\nHost: " + sim.address() + ":" + std::to_string(sim.apiPort()) +
                            "\r\nAccept: text/event-stream\r\n\r\n";
    ok_ = ok_ && ::send(fd_, req.data(), req.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(req.size());
  }
  ~StreamClient() { ::close(fd_); }
  StreamClient(const StreamClient&) = delete;
  StreamClient& operator=(const StreamClient&) = delete;
  [[nodiscard]] bool ok() const { return ok_; }
  // Reads what has come (waiting up to `limit` for more); false at the end.
  bool read(std::string& into, std::chrono::milliseconds limit) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(limit.count())) <= 0) return true;
    char buf[65536];
    const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
    if (n <= 0) return false;
    into.append(buf, static_cast<std::size_t>(n));
    return true;
  }

 private:
  int fd_ = -1;
  bool ok_ = false;
};

long rssKb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::atol(line.c_str() + 6);
  return -1;
}

struct Figures {
  double medianUs = 0, p99Us = 0;
  std::uint64_t datagrams = 0;
};

Figures serverFigures(const Sim& sim) {
  const auto s = sim.get()["server"];
  return {s["median_us"].get<double>(), s["p99_us"].get<double>(), s["datagrams"].get<std::uint64_t>()};
}

constexpr auto kRun = 6s;  // past the stream's 3 s stall timeout

// A sim with the mill, a host cycling it at about 1 kHz, `reading` pages
// that read their event stream (0 or 1) and `stalled` ones that never read
// it, for kRun: the card's figures, what the reading page got, and the
// sim's memory after 1 s and at the end.
struct StreamRun {
  Figures card;
  std::uint64_t frames = 0;  // whole frames the reading page got
  json lastFrame;
  long rssEarly = 0, rssLate = 0;
  std::size_t mostToAStalledPage = 0;  // bytes, before it was dropped
  bool stalledDropped = true;
};

StreamRun runWith(int n, bool reading, int stalled) {
  StreamRun r;
  Sim sim(loopback(n), {"--machine", "mill"});
  EXPECT_TRUE(sim.up());
  if (!sim.up()) return r;
  Host host(sim);
  std::vector<std::unique_ptr<StreamClient>> stuck;
  for (int i = 0; i < stalled; ++i) {
    stuck.push_back(std::make_unique<StreamClient>(sim, 4096));  // a small window: the sim sees the stall soon
    EXPECT_TRUE(stuck.back()->ok());
  }
  std::unique_ptr<StreamClient> reader;
  if (reading) reader = std::make_unique<StreamClient>(sim);
  std::string live, last;
  const auto start = Clock::now();
  bool early = false;
  while (Clock::now() - start < kRun) {
    if (reader) {
      EXPECT_TRUE(reader->read(live, 50ms)) << "the sim closed the page that reads";
      // Whole events: count the frames, keep the newest.
      for (std::size_t at; (at = live.find("\n\n")) != std::string::npos; live.erase(0, at + 2)) {
        if (live.rfind("data: ", 0) != 0) continue;
        ++r.frames;
        last = live.substr(6, at - 6);
      }
    } else {
      std::this_thread::sleep_for(50ms);
    }
    if (!early && Clock::now() - start > 1s) {
      early = true;
      r.rssEarly = rssKb(sim.pid());
    }
  }
  r.rssLate = rssKb(sim.pid());
  r.card = serverFigures(sim);
  r.lastFrame = json::parse(last, nullptr, false);
  // Each stalled page got at most what the socket buffers held and a
  // frame, then the end of its stream.
  for (auto& s : stuck) {
    std::string got;
    const auto end = Clock::now() + 3s;
    bool open = true;
    while (open && Clock::now() < end) open = s->read(got, 100ms);
    r.stalledDropped = r.stalledDropped && !open;
    r.mostToAStalledPage = std::max(r.mostToAStalledPage, got.size());
  }
  return r;
}

TEST(WebStream, AStalledPageNeitherSlowsTheCardNorGrowsTheSim) {
  const StreamRun none = runWith(10, false, 0);
  const StreamRun one = runWith(11, true, 0);
  const StreamRun stalled = runWith(12, true, 4);
  const auto seconds = std::chrono::duration_cast<std::chrono::seconds>(kRun).count();
  auto line = [&](const char* what, const StreamRun& r) {
    std::printf("  %-36s median %6.1f us, p99 %7.1f us over %6llu datagrams; sim VmRSS %ld -> %ld kB; "
                "frames read %llu\n",
                what, r.card.medianUs, r.card.p99Us, static_cast<unsigned long long>(r.card.datagrams), r.rssEarly,
                r.rssLate, static_cast<unsigned long long>(r.frames));
  };
  std::printf("card's server time per datagram, host at 1 kHz, %lld s each:\n", static_cast<long long>(seconds));
  line("no page", none);
  line("one page reading", one);
  line("one page reading, four stalled", stalled);
  ASSERT_TRUE(stalled.lastFrame.is_object());
  std::printf("  stream with the stalled pages: %s; most bytes a stalled page got: %zu\n",
              stalled.lastFrame["stream"].dump().c_str(), stalled.mostToAStalledPage);
  EXPECT_TRUE(stalled.stalledDropped) << "a stalled page was never dropped";
  EXPECT_LT(stalled.mostToAStalledPage, 1024U * 1024U) << "a stalled page was buffered for";
  EXPECT_GE(stalled.lastFrame["stream"]["dropped"].get<int>(), 4);
  EXPECT_EQ(stalled.lastFrame["stream"]["clients"].get<int>(), 1);
  // The page that reads gets frames, stalled pages or not. How many, and
  // the card's time per datagram, are figures (printed above): they follow
  // how this machine schedules the sim, the browser's stand-in and the
  // host. A frame is made once for every page, so stalled pages add nothing
  // to the card thread's work; the three medians above say what the
  // scheduling made of that.
  EXPECT_GT(stalled.frames, 0U) << "the page that reads got nothing";
  // scripts/test's ThreadSanitizer step runs this against a TSan daemon
  // (LBPKIT_BINARY) for the races between the event stream and the API
  // workers; TSan's shadow memory grows with every page touched, so there
  // the memory is printed, not judged.
  if (std::getenv("LBPKIT_SANITIZED_SIM") != nullptr) return;
  // The stalled pages would have been sent some 4 x 25 frames/s x 10 kB x
  // 6 s = 6 MB if anything held on to their frames.
  EXPECT_LT(stalled.rssLate - stalled.rssEarly, 3 * 1024) << "the sim grew";
}

}  // namespace
