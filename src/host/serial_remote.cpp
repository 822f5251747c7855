// SPDX-License-Identifier: MIT
#include "lbpkit/serial_remote.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <fmt/format.h>

#include <cerrno>
#include <cstring>

#include "lbpkit/wire/lbp.hpp"
#include "lbpkit/wire/crc8.hpp"
#include "lbpkit/wire/serial_speed.hpp"
#include "lbpkit/error.hpp"

namespace lbpkit {

namespace {
speed_t speedFor(unsigned baud) {
  if (const auto speed = wire::termiosSpeed(baud)) return static_cast<speed_t>(*speed);
  throw Error(fmt::format("{} baud is not a rate this serial port can be set to", baud));
}
}  // namespace

SerialRemote::SerialRemote(const std::string& path, unsigned baud, std::chrono::milliseconds timeout)
    : path_(path), timeout_(timeout) {
  // LBP bytes go only to a terminal (a serial port or a pty): a mistyped
  // path must not get them written into a file. Look before opening, since
  // opening some devices acts, and O_NONBLOCK so a FIFO cannot hang us.
  const speed_t speed = speedFor(baud);
  struct stat st{};
  if (::stat(path.c_str(), &st) == 0 && !S_ISCHR(st.st_mode))
    throw Error(fmt::format("{}: is {}, not a serial device (a tty or pty); refusing to write LBP bytes into it", path,
                            S_ISREG(st.st_mode)   ? "a regular file"
                            : S_ISDIR(st.st_mode) ? "a directory"
                            : S_ISFIFO(st.st_mode) ? "a FIFO"
                                                   : "not a character device"));
  fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC | O_NONBLOCK);
  if (fd_ < 0) throw Error(fmt::format("cannot open {}: {}", path, std::strerror(errno)));
  termios tio{};
  if (::fstat(fd_, &st) != 0 || !S_ISCHR(st.st_mode) || ::tcgetattr(fd_, &tio) != 0) {
    const int e = errno;
    ::close(fd_);
    fd_ = -1;
    throw Error(fmt::format("{}: is not a serial device (a tty or pty): {}; refusing to write LBP bytes into it", path,
                            S_ISCHR(st.st_mode) ? std::strerror(e) : "not a character device"));
  }
  // Back to blocking I/O: transact() waits with poll() and reads what is there.
  ::fcntl(fd_, F_SETFL, ::fcntl(fd_, F_GETFL) & ~O_NONBLOCK);
  ::cfmakeraw(&tio);
  ::cfsetspeed(&tio, speed);
  tio.c_cflag |= CLOCAL | CREAD;
  ::tcsetattr(fd_, TCSANOW, &tio);
  ::tcflush(fd_, TCIOFLUSH);
}

SerialRemote::~SerialRemote() {
  if (fd_ >= 0) ::close(fd_);
}

std::vector<std::uint8_t> SerialRemote::transact(std::span<const std::uint8_t> command, std::size_t replyBytes,
                                                 const std::string& what) {
  std::vector<std::uint8_t> frame(command.begin(), command.end());
  frame.push_back(wire::lbp::crc8(frame));
  // Stale characters from an earlier, timed-out exchange would shift this reply.
  ::tcflush(fd_, TCIFLUSH);
  if (::write(fd_, frame.data(), frame.size()) != static_cast<ssize_t>(frame.size()))
    throw Error(fmt::format("{}: write failed: {}", path_, std::strerror(errno)));
  ++transactions_;
  std::vector<std::uint8_t> reply;
  const auto deadline = std::chrono::steady_clock::now() + timeout_;
  while (reply.size() < replyBytes + 1) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) break;
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) continue;
    std::uint8_t buf[64];
    const ssize_t n = ::read(fd_, buf, std::min(sizeof buf, replyBytes + 1 - reply.size()));
    if (n > 0) reply.insert(reply.end(), buf, buf + n);
  }
  if (reply.size() < replyBytes + 1)
    throw Error(fmt::format("{}: no answer to {} ({} of {} bytes): is the remote powered, in setup mode "
                            "(W4/W12), and at 115200 baud?",
                            path_, what, reply.size(), replyBytes + 1));
  if (wire::lbp::crc8(reply) != 0) throw Error(fmt::format("{}: the answer to {} has a bad CRC", path_, what));
  reply.pop_back();
  return reply;
}

std::uint64_t SerialRemote::read(std::uint16_t address, unsigned size) {
  const std::uint8_t cmd[3] = {wire::lbp::readHeader(static_cast<std::uint8_t>(size), true),
                               static_cast<std::uint8_t>(address), static_cast<std::uint8_t>(address >> 8)};
  const auto r = transact(cmd, size, fmt::format("a read of {} bytes at 0x{:04X}", size, address));
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < r.size(); ++i) v |= static_cast<std::uint64_t>(r[i]) << (8 * i);
  return v;
}

void SerialRemote::write(std::uint16_t address, unsigned size, std::uint64_t value) {
  localWrite(wire::lbp::local_write::kStatus, 0);  // so the status after the write speaks of it alone
  std::vector<std::uint8_t> cmd = {wire::lbp::writeHeader(static_cast<std::uint8_t>(size), true),
                                   static_cast<std::uint8_t>(address), static_cast<std::uint8_t>(address >> 8)};
  for (unsigned i = 0; i < size; ++i) cmd.push_back(static_cast<std::uint8_t>(value >> (8 * i)));
  transact(cmd, 0, fmt::format("a write of {} bytes at 0x{:04X}", size, address));
  // A refused write still gets its CRC; the status tells.
  const auto status = localRead(wire::lbp::local_read::kStatus);
  if (status & wire::lbp::status::kInvalidWrite) {
    const std::uint8_t clear[2] = {wire::lbp::local_write::kStatus, 0};
    transact(clear, 0, "clearing the LBP status");
    throw Error(fmt::format("{}: the remote refused the write at 0x{:04X} (read only, NV access off, or its EEPROM "
                            "could not save the value)",
                            path_, address));
  }
}

std::uint8_t SerialRemote::localRead(std::uint8_t command) {
  const std::uint8_t cmd[1] = {command};
  return transact(cmd, 1, fmt::format("local read 0x{:02X}", command)).at(0);
}

void SerialRemote::localWrite(std::uint8_t command, std::uint8_t value) {
  const std::uint8_t cmd[2] = {command, value};
  transact(cmd, 0, fmt::format("local write 0x{:02X}", command));
}

SerialRemote::Discovery SerialRemote::discoveryRpc() {
  const std::uint8_t cmd[1] = {wire::lbp::special_rpc::kDiscovery};
  const auto r = transact(cmd, 6, "the discovery RPC");
  return {r[0], r[1], static_cast<std::uint16_t>(r[2] | (r[3] << 8)), static_cast<std::uint16_t>(r[4] | (r[5] << 8))};
}

std::uint32_t SerialRemote::unitNumber() {
  const std::uint8_t cmd[1] = {wire::lbp::special_rpc::kUnitNumber};
  const auto r = transact(cmd, 4, "the unit number RPC");
  return std::uint32_t{r[0]} | (std::uint32_t{r[1]} << 8) | (std::uint32_t{r[2]} << 16) | (std::uint32_t{r[3]} << 24);
}

std::string SerialRemote::cardName() {
  std::string s;
  for (std::uint8_t c = 0; c < 4; ++c) s.push_back(static_cast<char>(localRead(static_cast<std::uint8_t>(wire::lbp::local_read::kCardName0 + c))));
  return s;
}

}  // namespace lbpkit
