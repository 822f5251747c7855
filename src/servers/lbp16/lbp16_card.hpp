// A 7I92-style Ethernet card's LBP16 face: the memory spaces hm2_eth and
// mesaflash use, around the HostMot2 register file (docs/protocol-facts.md#lbp16; LBP16 as
// LinuxCNC's hm2_eth and mesaflash speak it).
//
//   0 HostMot2 registers (32-bit)      1 Ethernet chip (16-bit, read only)
//   2 Ethernet EEPROM: MAC, name, IP   3 FPGA flash: address (0), data (4:
//     reads and page programs advance the address), ID (8), sector erase (C)
//   4 timer, with the scratch words hm2_eth echoes its packet counters in
//   6 communication control/status counters   7 board info ("7I92")
// Each space also has a 16-byte area-info block (info-area access).
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

#include "hostmot2/card.hpp"
#include "lbpkit/wire/lbp16.hpp"

namespace net {

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
  };

  struct Counters {
    std::uint64_t packets = 0;
    std::uint64_t replies = 0;
    std::uint64_t parseErrors = 0;   // truncated or oversized datagrams
    std::uint64_t memoryErrors = 0;  // unknown spaces, widths, counts past an area's end
    std::uint64_t writeErrors = 0;   // writes to read-only spaces
  };

  Lbp16Card(hm2::HostMot2Card& card, Identity identity);

  // One request datagram at simulated time `now`; the reply goes to `reply`
  // (kMaxDatagram bytes). Returns the reply length: 0 when the datagram
  // holds no reads.
  std::size_t handle(std::span<const std::uint8_t> request, std::span<std::uint8_t> reply, hm2::SimTime now);

  // The Ethernet EEPROM's MAC, IP and name as it now holds them: what
  // mesaflash wrote (with the write enable) shows here at once, while the
  // card answers with identity() until it powers up again.
  struct Eeprom {
    std::array<std::uint8_t, 6> mac{};
    std::array<std::uint8_t, 4> ip{};
    std::string name;
  };

  [[nodiscard]] const Counters& counters() const { return counters_; }
  [[nodiscard]] const Identity& identity() const { return identity_; }
  [[nodiscard]] Eeprom eeprom() const;
  hm2::HostMot2Card& card() { return card_; }

 private:
  struct Area {
    const char* name;
    std::uint32_t bytes;      // size of the space
    std::uint8_t widths;      // bit 0: 8-bit ... bit 3: 64-bit access
    std::uint8_t type;        // 1 registers, 2 memory, 14 EEPROM, 15 flash
    bool writable;
  };
  static const Area* area(std::uint8_t space);

  std::uint64_t read(std::uint8_t space, std::uint32_t address, unsigned size, hm2::SimTime now);
  void write(std::uint8_t space, std::uint32_t address, unsigned size, std::uint64_t value, hm2::SimTime now);
  std::uint16_t readWord16(std::uint8_t space, std::uint32_t address, hm2::SimTime now);
  std::uint8_t infoByte(std::uint8_t space, std::uint32_t offset) const;

  hm2::HostMot2Card& card_;
  Identity identity_;
  Counters counters_;
  std::array<std::uint16_t, 8> pointer_{};  // per-space address pointers
  std::array<std::uint16_t, 4> scratch_{};  // timer space 0x10..0x17
  std::array<std::uint8_t, 128> eeprom_{};
  std::uint16_t ledMode_ = 0;
  std::uint16_t commScratch_ = 0;
  // The write-enable key written to comm-control 0x1A in this datagram:
  // 0x5A02 lets the EEPROM be written, 0x5A03 the flash.
  std::uint16_t writeEnable_ = 0;
  // The configuration flash: a blank 16 Mbit part (mesaflash --write
  // installs its boot block and a bitfile; --verify reads them back).
  std::vector<std::uint8_t> flash_;
  std::uint32_t flashAddress_ = 0;
};

}  // namespace net
