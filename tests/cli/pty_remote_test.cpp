// SPDX-License-Identifier: MIT
// `lbpkit remote --pty` as an external program sees it: open the pty, talk
// LBP through it, stop the daemon with SIGTERM.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "lbp/protocol.hpp"
#include "support/process.hpp"
#include "support/temp_dir.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace lbp = lbpkit::model::lbp;

namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes exchange(int fd, Bytes command, std::size_t expect) {
  command.push_back(lbp::crc8(command));
  EXPECT_EQ(::write(fd, command.data(), command.size()), static_cast<ssize_t>(command.size()));
  Bytes reply;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
  while (reply.size() < expect && std::chrono::steady_clock::now() < deadline) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 50) <= 0) continue;
    std::uint8_t buf[64];
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n > 0) reply.insert(reply.end(), buf, buf + n);
  }
  return reply;
}

TEST(PtyRemote, AnExternalProgramTalksLbpThroughThePty) {
  const auto state = std::filesystem::temp_directory_path() / ("lbpkit-pty-" + std::to_string(::getpid()));
  test_support::removeStateFiles(state);
  test_support::Daemon d({"remote", "--pty", "--setup", "--state", state.string()});
  const std::string out = d.readUntil("serial device:");
  const auto at = out.find("serial device: ");
  ASSERT_NE(at, std::string::npos) << out;
  const std::string path = out.substr(at + 15, out.find('\n', at) - at - 15);
  EXPECT_NE(out.find("setup mode at 115200 baud"), std::string::npos) << out;

  const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY);
  ASSERT_GE(fd, 0) << path;
  termios tio{};
  ASSERT_EQ(::tcgetattr(fd, &tio), 0);
  ::cfmakeraw(&tio);
  ASSERT_EQ(::tcsetattr(fd, TCSANOW, &tio), 0);

  EXPECT_EQ(exchange(fd, {lbp::local_read::kCookie}, 2), (Bytes{0x5A, lbp::crc8(Bytes{0x5A})}));
  Bytes name;
  for (std::uint8_t c = 0xD0; c <= 0xD3; ++c) name.push_back(exchange(fd, {c}, 2).at(0));
  EXPECT_EQ(std::string(name.begin(), name.end()), "7I77");
  const Bytes unit = exchange(fd, {lbp::special_rpc::kUnitNumber}, 5);
  ASSERT_EQ(unit.size(), 5U);
  EXPECT_EQ(unit[3], 0x12);  // field I/O
  EXPECT_EQ(lbp::crc8(unit), 0);
  // A corrupted command gets no answer; the next one does.
  Bytes bad{lbp::local_read::kCookie, 0x00};
  EXPECT_EQ(::write(fd, bad.data(), 2), 2);
  ::usleep(20000);
  EXPECT_EQ(exchange(fd, {lbp::local_read::kCrcErrorCount}, 2).at(0), 1);
  ::close(fd);

  EXPECT_EQ(d.stop(), 0);
  EXPECT_TRUE(std::filesystem::exists(state));  // EEPROM state saved
  test_support::removeStateFiles(state);
}

// A client that writes and never reads must not wedge the remote: a real
// USB-RS422 adapter whose host stops reading loses characters, it does not
// stop the board. SIGTERM still stops it, and the next client's first answer
// is its own, not a stale one.
TEST(PtyRemote, AClientThatNeverReadsCannotWedgeIt) {
  const auto state = std::filesystem::temp_directory_path() / ("lbpkit-pty-wedge-" + std::to_string(::getpid()));
  test_support::removeStateFiles(state);
  test_support::Daemon d({"remote", "--pty", "--setup", "--state", state.string()});
  const std::string path = d.value("serial device: ");
  ASSERT_FALSE(path.empty());
  {
    const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
    ASSERT_GE(fd, 0) << path;
    termios tio{};
    ASSERT_EQ(::tcgetattr(fd, &tio), 0);
    ::cfmakeraw(&tio);
    ASSERT_EQ(::tcsetattr(fd, TCSANOW, &tio), 0);
    // 64 KiB of cookie reads: 128 KiB of answers nobody reads, far more
    // than a pty buffers.
    const Bytes cmd{lbp::local_read::kCookie, lbp::crc8(Bytes{lbp::local_read::kCookie})};
    Bytes flood;
    for (int i = 0; i < 32768; ++i) flood.insert(flood.end(), cmd.begin(), cmd.end());
    std::size_t sent = 0;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (sent < flood.size() && std::chrono::steady_clock::now() < deadline) {
      const ssize_t n = ::write(fd, flood.data() + sent, flood.size() - sent);
      if (n > 0) sent += static_cast<std::size_t>(n);
      else ::usleep(1000);
    }
    EXPECT_EQ(sent, flood.size()) << "the remote stopped reading its commands";
    ::usleep(300000);
    ::close(fd);
  }
  ::usleep(300000);  // a pause, as between two programs
  // The next client gets exactly the answer to its own command.
  const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY);
  ASSERT_GE(fd, 0) << path;
  termios tio{};
  ASSERT_EQ(::tcgetattr(fd, &tio), 0);
  ::cfmakeraw(&tio);
  ASSERT_EQ(::tcsetattr(fd, TCSANOW, &tio), 0);
  const Bytes unit = exchange(fd, {lbp::special_rpc::kUnitNumber}, 5);
  ASSERT_EQ(unit.size(), 5U);
  EXPECT_EQ(unit[3], 0x12);
  EXPECT_EQ(lbp::crc8(unit), 0);
  ::close(fd);

  // SIGTERM stops it promptly.
  EXPECT_EQ(d.stopWithin(std::chrono::seconds(3)), 0);
  test_support::removeStateFiles(state);
}

}  // namespace
