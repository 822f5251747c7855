// SPDX-License-Identifier: MIT
// The host clock's watch on its host's process (docs/clocks.md): the
// process behind a host's socket is found, and it is sighted runnable
// while it runs or waits for a CPU, never while it sleeps, is stopped or
// is gone. The hosts are children of the test, each holding a UDP socket
// and then spinning, sleeping or stopped as the test says.
#include "daemon/host_watch.hpp"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "process/host_process.hpp"
#include "support/wait.hpp"

namespace process = lbpkit::process;
namespace server = lbpkit::server;

namespace {

using namespace std::chrono_literals;

// A UDP socket on 127.0.0.1 at a port the kernel chose, and that address.
int boundSocket(sockaddr_in& at) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  at = {};
  at.sin_family = AF_INET;
  at.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (fd < 0 || ::bind(fd, reinterpret_cast<const sockaddr*>(&at), sizeof at) != 0) return -1;
  socklen_t len = sizeof at;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&at), &len);
  return fd;
}

// A host in a child: it binds its socket, says where, then spins or sleeps.
class ChildHost {
 public:
  explicit ChildHost(bool spin) {
    int fds[2];
    if (::pipe(fds) != 0) return;
    pid_ = ::fork();
    if (pid_ == 0) {
      ::close(fds[0]);
      sockaddr_in at{};
      if (boundSocket(at) < 0) ::_exit(1);
      if (::write(fds[1], &at, sizeof at) != static_cast<ssize_t>(sizeof at)) ::_exit(1);
      for (;;)
        if (!spin) ::pause();
    }
    ::close(fds[1]);
    if (::read(fds[0], &at_, sizeof at_) != static_cast<ssize_t>(sizeof at_)) at_ = {};
    ::close(fds[0]);
  }
  ~ChildHost() { kill(); }
  ChildHost(const ChildHost&) = delete;
  ChildHost& operator=(const ChildHost&) = delete;
  void kill() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }
  [[nodiscard]] pid_t pid() const { return pid_; }
  [[nodiscard]] const sockaddr_in& at() const { return at_; }

 private:
  pid_t pid_ = -1;
  sockaddr_in at_{};
};

TEST(HostProcess, TheOwnerOfAUdpSocketIsTheProcessThatHoldsIt) {
  sockaddr_in at{};
  const int fd = boundSocket(at);
  ASSERT_GE(fd, 0);
  EXPECT_EQ(process::udpSocketOwner(at.sin_addr.s_addr, ntohs(at.sin_port)), ::getpid());
  ::close(fd);
  EXPECT_EQ(process::udpSocketOwner(at.sin_addr.s_addr, ntohs(at.sin_port)), std::nullopt) << "closed";
  ChildHost child(false);
  ASSERT_GT(child.pid(), 0);
  EXPECT_EQ(process::udpSocketOwner(child.at().sin_addr.s_addr, ntohs(child.at().sin_port)), child.pid());
}

TEST(HostProcess, ThreadsAreRunnableWaitingStoppedOrGone) {
  EXPECT_EQ(process::threadsState(::getpid()), process::ThreadsState::Runnable) << "this thread, reading";
  ChildHost sleeper(false);
  ASSERT_GT(sleeper.pid(), 0);
  EXPECT_TRUE(test_support::waitFor(
      [&] { return process::threadsState(sleeper.pid()) == process::ThreadsState::Waiting; }, 5s));
  ::kill(sleeper.pid(), SIGSTOP);
  EXPECT_TRUE(test_support::waitFor(
      [&] { return process::threadsState(sleeper.pid()) == process::ThreadsState::Stopped; }, 5s));
  const pid_t gone = sleeper.pid();
  sleeper.kill();
  EXPECT_EQ(process::threadsState(gone), process::ThreadsState::Gone);
}

// The watch, told of a cycle from a child's socket: a spinning child is
// sighted runnable once it has been silent kLook; a sleeping or stopped
// one is found but never sighted.
TEST(HostWatch, SightsAHostThatRunsAndNoneThatSleepsOrIsStopped) {
  ChildHost spinner(true);
  ASSERT_GT(spinner.pid(), 0);
  {
    server::HostWatch watch;
    watch.cycled(spinner.at());
    EXPECT_TRUE(test_support::waitFor([&] { return watch.runningAt().count() != 0; }, 5s));
    EXPECT_EQ(watch.pid(), spinner.pid());
  }
  ChildHost sleeper(false);
  ASSERT_GT(sleeper.pid(), 0);
  ASSERT_TRUE(test_support::waitFor(
      [&] { return process::threadsState(sleeper.pid()) == process::ThreadsState::Waiting; }, 5s));
  for (const bool stop : {false, true}) {
    if (stop) ::kill(sleeper.pid(), SIGSTOP);
    server::HostWatch watch;
    watch.cycled(sleeper.at());
    ASSERT_TRUE(test_support::waitFor([&] { return watch.pid() == sleeper.pid(); }, 5s));
    std::this_thread::sleep_for(10 * server::HostWatch::kLook);
    EXPECT_EQ(watch.runningAt().count(), 0) << (stop ? "stopped" : "asleep");
  }
}

}  // namespace
