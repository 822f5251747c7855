// SPDX-License-Identifier: MIT
// What `lbpkit sim --log-level debug` tells a driver developer: every
// register access nothing decodes, with its address and value.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <string>

#include "lbpkit/wire/lbp16.hpp"
#include "support/process.hpp"
#include "support/sim_child.hpp"
#include "support/temp_dir.hpp"

namespace {

TEST(SimLog, DebugLevelNamesWritesThatNothingDecodes) {
  int out = -1, err = -1, ready = -1;
  const pid_t pid = test_support::spawn(
      {"sim", "--bind", "127.0.0.94:0", "--api", "0", "--no-realtime", "--log-level", "debug", "--state",
       ::testing::TempDir() + "sim-log-" + std::to_string(::getpid()) + ".eeprom", "--ready-fd", "3"},
      out, err, &ready);
  std::string greeting, log;
  test_support::readUntil(ready, greeting, "}", std::chrono::seconds(5));
  ::close(ready);
  const auto g = nlohmann::json::parse(greeting, nullptr, false);
  ASSERT_TRUE(g.is_object() && g.contains("cards")) << greeting;
  const int port = g["cards"][0]["lbp16"]["port"].get<int>();

  // hm2_eth-style write of 0x5A04 to 0x7F00, where this card has no module.
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(static_cast<std::uint16_t>(port));
  ::inet_pton(AF_INET, "127.0.0.94", &sa.sin_addr);
  const std::uint16_t cmd = lbpkit::wire::lbp16::hm2Write(1);
  const std::uint8_t datagram[8] = {static_cast<std::uint8_t>(cmd), static_cast<std::uint8_t>(cmd >> 8), 0x00, 0x7F,
                                    0x04, 0x5A, 0x00, 0x00};
  ASSERT_EQ(::sendto(fd, datagram, sizeof datagram, 0, reinterpret_cast<sockaddr*>(&sa), sizeof sa), 8);
  ::close(fd);
  test_support::readUntil(err, log, "0x00005A04", std::chrono::seconds(5));
  EXPECT_NE(log.find("unmapped_write: address 0x7F00, value 0x00005A04"), std::string::npos) << log;

  ::kill(pid, SIGTERM);
  ::waitpid(pid, nullptr, 0);
  ::close(out);
  ::close(err);
  // Both remotes' EEPROM images (the field I/O's and the analog's).
  const std::string state = ::testing::TempDir() + "sim-log-" + std::to_string(::getpid()) + ".eeprom";
  test_support::removeStateFiles(state);
}

}  // namespace
