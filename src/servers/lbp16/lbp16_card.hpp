// SPDX-License-Identifier: MIT
// A 7I92-style Ethernet card's LBP16 face: the memory spaces hm2_eth and
// mesaflash use, around the HostMot2 register file (docs/protocol-facts.md#lbp16;
// LBP16 as Mesa's Ethernet firmware implements it, hostmot2-firmware
// src/etherhm2.zip: ETHERHM2.INC, LBPPARSE.ASM, ETHERINI.ASM; LinuxCNC's
// lbp16.h and mesaflash name the same words).
//
//   0 HostMot2 registers (32-bit)      1 Ethernet chip registers (16-bit)
//   2 Ethernet EEPROM: MAC, name, IP (16-bit; 0x00..0x1F read only)
//   3 FPGA flash: address (0), data (4: reads and page programs advance the
//     address), ID (8), sector erase (C)
//   4 timer: microsecond timestamp, WaituS, HM2Timeout, WaitForHM2RefTime,
//     WaitForHM2Timer1..4, eight scratch words (hm2_eth echoes its packet
//     counters there)
//   6 communication control/status: error flags and counters, LED mode,
//     scratch, write enable, reset, FPGA configuration (reload)
//   7 board info ("7I92", read only)
// What differs between cards (board name, flash, FPGA family and how it
// reloads) comes from the card's catalogue entry (cards::Lbp16Details).
// Each space also has a 16-byte area-info block (info-area access): cookie,
// size and type, ranges, the space's address pointer, name.
//
// handle() is the per-datagram path: no allocation, no system calls. Bad
// datagrams are counted (as the card's error registers do) and answered as
// far as they parse; well-formed reads always get their full length.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <filesystem>
#include <memory>
#include <mutex>

#include "hostmot2/card.hpp"
#include "lbp16/flash_file.hpp"
#include "lbpkit/wire/lbp16.hpp"

namespace lbpkit::server {

namespace lbp16 = lbpkit::wire::lbp16;

class Lbp16Card {
 public:
  static constexpr std::size_t kMaxDatagram = 1472;  // one Ethernet frame of UDP payload

  struct Identity {
    std::array<std::uint8_t, 6> mac{0x02, 0x00, 0x4D, 0x45, 0x53, 0x41};  // locally administered
    std::array<std::uint8_t, 4> ip{127, 0, 0, 1};
    std::string name = "7I92";
    std::uint16_t lbp16Version = 3;
    std::uint16_t firmwareVersion = 17;
    std::uint16_t jumpers = 1;  // IP from EEPROM
    // The configuration flash's file (flash_file.hpp), kept across runs;
    // empty: the flash lives in memory and starts blank.
    std::filesystem::path flashFile;
  };

  // Lifetime totals (the space-6 registers are 16 bits and the host may
  // clear them; these are for the control API).
  struct Counters {
    std::uint64_t packets = 0;
    std::uint64_t replies = 0;
    std::uint64_t parseErrors = 0;   // truncated commands, widths or spaces the card lacks, count 0
    std::uint64_t memoryErrors = 0;  // addresses past an area's end, replies bigger than a frame
    std::uint64_t writeErrors = 0;   // writes to read-only spaces or bytes, or without the write enable
    std::uint64_t rxErrors = 0;      // datagrams bigger than a frame (a real card never receives them whole)
    std::uint64_t txErrors = 0;      // replies the network did not take (noteSendFailed)
    std::uint64_t hm2Timeouts = 0;   // WaitForHM2 waits that ended by HM2Timeout
    std::uint64_t reloads = 0;       // FPGA reconfigurations the host asked for (mesaflash --reload)
  };

  // Bits of the error register (space 6, 0x00): set when the error happens,
  // cleared only by the host writing the register (LBPPARSE.ASM,
  // ETHERHM2.ASM: errorreg).
  struct ErrorBit {
    static constexpr std::uint16_t kParse = 0x01;
    static constexpr std::uint16_t kMemory = 0x02;
    static constexpr std::uint16_t kWrite = 0x04;
    static constexpr std::uint16_t kRx = 0x08;
    static constexpr std::uint16_t kTx = 0x10;
    static constexpr std::uint16_t kHm2Timeout = 0x20;
  };

  // Throws std::runtime_error when identity.flashFile is a file the card
  // will not use (flash_file.hpp: loadFlashFile() tells beforehand).
  Lbp16Card(model::hm2::HostMot2Card& card, Identity identity);
  ~Lbp16Card();
  Lbp16Card(const Lbp16Card&) = delete;
  Lbp16Card& operator=(const Lbp16Card&) = delete;

  // One request datagram at simulated time `now`; the reply goes to `reply`
  // (kMaxDatagram bytes). Returns the reply length: 0 when the datagram
  // holds no reads.
  std::size_t handle(std::span<const std::uint8_t> request, std::span<std::uint8_t> reply, model::hm2::SimTime now);

  // The Ethernet EEPROM's MAC, IP and name as it now holds them: what
  // mesaflash wrote (with the write enable) shows here at once, while the
  // card answers with identity() until it powers up again.
  struct Eeprom {
    std::array<std::uint8_t, 6> mac{};
    std::array<std::uint8_t, 4> ip{};
    std::string name;
  };

  // The reply to the last datagram did not go out: counted as a TX error.
  void noteSendFailed();

  [[nodiscard]] const Counters& counters() const { return counters_; }
  // The error register (space 6, 0x00) as the host reads it.
  [[nodiscard]] std::uint16_t errorRegister() const { return status_[0]; }
  // The flash as it now holds, and its file's last save error ("" when fine).
  [[nodiscard]] std::span<const std::uint8_t> flash() const { return flash_; }
  [[nodiscard]] std::string flashSaveError() const { return saver_ ? saver_->lastError() : std::string(); }
  [[nodiscard]] const Identity& identity() const { return identity_; }
  [[nodiscard]] Eeprom eeprom() const;
  model::hm2::HostMot2Card& card() { return card_; }

 private:
  struct Area {
    const char* name;       // 8 characters at most (info area words 4..7)
    std::uint16_t sizeWord;  // info word 1: bit 15 writable, 14..8 type, 3..0 widths (8/16/32/64)
    std::uint16_t ranges;    // info word 2, as the firmware has it
    std::uint32_t bytes;     // how far addresses go
  };
  static const Area* area(std::uint8_t space);

  std::uint64_t read(std::uint8_t space, std::uint32_t address, unsigned size, model::hm2::SimTime now);
  void write(std::uint8_t space, std::uint32_t address, unsigned size, std::uint64_t value, model::hm2::SimTime now);
  std::uint16_t readWord16(std::uint8_t space, std::uint32_t address, model::hm2::SimTime now);
  void writeWord16(std::uint8_t space, std::uint32_t address, std::uint16_t value, model::hm2::SimTime now);
  std::uint8_t infoByte(std::uint8_t space, std::uint32_t offset) const;
  void error(std::uint16_t bit);
  // A wait of the timer space: the rest of the datagram happens this much later.
  void wait(std::chrono::microseconds us) { waited_ += us; }
  void waitForHm2();
  // A word written to space 6's configuration register (0x1E): the
  // card's FPGA family decides what reloads it (docs/cards.md#lbp16-per-card).
  void configure(std::uint16_t value, model::hm2::SimTime now);
  void flashChanged() {
    if (saver_) saver_->changed();
  }

  model::hm2::HostMot2Card& card_;
  Identity identity_;
  Counters counters_;
  std::array<std::uint16_t, 8> pointer_{};  // per-space address pointers (info word 3)
  std::uint16_t infoPointer_ = 0;           // the info areas' one pointer (the firmware's lbpcaddr)
  // Space 6 as the host reads and writes it (16 words): error register,
  // parse/memory/write error counts, RX packets/UDP/bad, TX packets/UDP/bad,
  // LED mode, debug LED pointer, scratch, write enable, reset, ICAP.
  std::array<std::uint16_t, 16> status_{};
  // Space 4: timestamp, WaituS, HM2Timeout, WaitForHM2RefTime, Timer1..4,
  // then eight scratch words.
  std::array<std::uint16_t, 16> timer_{};
  std::array<std::uint16_t, 128> ethernetChip_{};  // space 1: 16-bit registers 0x00..0xFE
  std::array<std::uint8_t, 128> eeprom_{};
  // How long the timer space's waits have delayed this datagram so far.
  std::chrono::microseconds waited_{0};
  // The configuration flash: the card's part (16 Mbit on every card here), blank or as its file kept it
  // (mesaflash --write installs its boot block and a bitfile; --verify
  // reads them back). Changed only on the card thread, under flashMutex_
  // (the saver copies it under the same lock).
  std::vector<std::uint8_t> flash_;
  std::uint32_t flashBytes_;  // the card's part (cards::Lbp16Details)
  std::uint32_t flashAddress_ = 0;
  std::uint16_t icapLast_ = 0;  // the previous ICAP word (Xilinx cards)
  bool reloading_ = false;      // the FPGA reloads: the rest of this datagram is never parsed
  std::mutex flashMutex_;
  std::unique_ptr<FlashSaver> saver_;
};

}  // namespace lbpkit::server
