// SPDX-License-Identifier: MIT
// LBP16: the register protocol of Mesa's Ethernet cards (7I92 and kin) over
// UDP port 27181 (docs/protocol-facts.md#lbp16; LinuxCNC's lbp16.h and
// mesaflash agree).
//
// A datagram holds commands back to back. Each is a 16-bit little-endian
// command word, an optional 16-bit little-endian address, and for writes the
// data. Reads are answered with their data only, concatenated in order.
#pragma once

#include <cstdint>

namespace lbpkit::wire::lbp16 {

inline constexpr std::uint16_t kPort = 27181;

inline constexpr std::uint16_t kWrite = 0x8000;
inline constexpr std::uint16_t kAddress = 0x4000;  // a 16-bit address follows
inline constexpr std::uint16_t kInfoArea = 0x2000;
inline constexpr std::uint16_t kAutoIncrement = 0x0080;
inline constexpr std::uint16_t kCountMask = 0x007F;  // 0..127 transfers

enum class Space : std::uint8_t {
  HostMot2 = 0,
  EthernetChip = 1,
  Eeprom = 2,
  Flash = 3,
  Timer = 4,
  CommControl = 6,
  BoardInfo = 7,
};

struct Command {
  bool write = false;
  bool hasAddress = false;
  bool infoArea = false;
  std::uint8_t space = 0;
  std::uint8_t size = 1;  // bytes per transfer: 1, 2, 4, 8
  bool autoIncrement = false;
  std::uint8_t count = 0;

  static constexpr Command decode(std::uint16_t w) {
    return Command{(w & kWrite) != 0,
                   (w & kAddress) != 0,
                   (w & kInfoArea) != 0,
                   static_cast<std::uint8_t>((w >> 10) & 7U),
                   static_cast<std::uint8_t>(1U << ((w >> 8) & 3U)),
                   (w & kAutoIncrement) != 0,
                   static_cast<std::uint8_t>(w & kCountMask)};
  }
  [[nodiscard]] constexpr std::uint16_t encode() const {
    const unsigned sz = size >= 8 ? 3 : size >= 4 ? 2 : size >= 2 ? 1 : 0;
    return static_cast<std::uint16_t>((write ? kWrite : 0) | (hasAddress ? kAddress : 0) | (infoArea ? kInfoArea : 0) |
                                      (static_cast<unsigned>(space & 7U) << 10) | (sz << 8) |
                                      (autoIncrement ? kAutoIncrement : 0) | (count & kCountMask));
  }
  [[nodiscard]] constexpr unsigned dataBytes() const { return static_cast<unsigned>(size) * count; }
};

// Spaces' info areas and the write-enable keys written to the CommControl
// space before EEPROM or flash may change (what mesaflash does).
inline constexpr std::uint16_t kInfoAreaCookie = 0x5A00;  // first word of every space's info area
inline constexpr std::uint16_t kEepromWriteEnableKey = 0x5A02;
inline constexpr std::uint16_t kFlashWriteEnableKey = 0x5A03;

// The EEPROM space as hm2_eth and mesaflash read it: MAC at 0x02..0x07
// (each 16-bit word holds its pair with the first byte high; word 0x06 is
// MAC[0..1]), the card name at 0x10, the IP at 0x20 (low word c.d) and 0x22
// (high word a.b).
namespace eeprom {
inline constexpr std::uint16_t kMac = 0x02;
inline constexpr std::uint16_t kCardName = 0x10;
inline constexpr std::uint16_t kIp = 0x20;
inline constexpr std::uint16_t kSize = 0x80;
}  // namespace eeprom

// The timer space's scratch words (0x10..0x17), where hm2_eth echoes its
// packet counters to pair replies with requests, and the comm-control
// space's scratch word.
namespace timer {
inline constexpr std::uint16_t kMicroseconds = 0x00;  // free-running microsecond timestamp
inline constexpr std::uint16_t kScratch = 0x10;
inline constexpr std::uint16_t kScratchEnd = 0x18;
}  // namespace timer
namespace comm {
inline constexpr std::uint16_t kEepromWriteEnable = 0x1A;  // where the write-enable keys go
inline constexpr std::uint16_t kScratch = 0x18;
}  // namespace comm

// Ready-made words.
constexpr std::uint16_t hm2Read(unsigned words) {
  return Command{false, true, false, 0, 4, true, static_cast<std::uint8_t>(words)}.encode();
}
constexpr std::uint16_t hm2Write(unsigned words) {
  return Command{true, true, false, 0, 4, true, static_cast<std::uint8_t>(words)}.encode();
}

}  // namespace lbpkit::wire::lbp16
