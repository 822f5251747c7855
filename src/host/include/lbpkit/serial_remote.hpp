// SPDX-License-Identifier: MIT
// LBP straight to one remote over a serial line (a USB-RS422 adapter, or the
// pseudo-terminal of `lbpkit remote --pty`), as Mesa's RPD/WPD do: setup
// mode, 115200 baud, every command with its CRC (manual: LBP; RPD, WPD).
#pragma once

#include <chrono>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "lbpkit/discovery.hpp"

namespace lbpkit {

class SerialRemote final : public RemoteAccess {
 public:
  explicit SerialRemote(const std::string& path, unsigned baud = 115200,
                        std::chrono::milliseconds timeout = std::chrono::milliseconds(200));
  ~SerialRemote() override;
  SerialRemote(const SerialRemote&) = delete;
  SerialRemote& operator=(const SerialRemote&) = delete;

  std::uint64_t read(std::uint16_t address, unsigned size) override;
  void write(std::uint16_t address, unsigned size, std::uint64_t value) override;
  std::uint8_t localRead(std::uint8_t command) override;
  void localWrite(std::uint8_t command, std::uint8_t value) override;
  [[nodiscard]] std::uint64_t transactions() const override { return transactions_; }
  [[nodiscard]] std::string where() const override { return path_; }

  struct Discovery {
    std::uint8_t rxSize, txSize;
    std::uint16_t ptoc, gtoc;
  };
  Discovery discoveryRpc();
  std::uint32_t unitNumber();
  std::string cardName();

  // One command (CRC appended); returns the reply's data bytes after checking its CRC.
  std::vector<std::uint8_t> transact(std::span<const std::uint8_t> command, std::size_t replyBytes,
                                     const std::string& what);

 private:
  std::string path_;
  int fd_ = -1;
  std::chrono::milliseconds timeout_;
  std::uint64_t transactions_ = 0;
};

}  // namespace lbpkit
