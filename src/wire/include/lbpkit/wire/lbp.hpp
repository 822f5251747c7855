// SPDX-License-Identifier: MIT
// LBP, the remote processors' byte protocol: command headers, local
// commands, status bits and the special RPCs (docs/protocol-facts.md#lbp;
// manual: REFERENCE INFORMATION, LBP; local addresses the manual leaves out
// are the firmware's LBP.INC ones).
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

namespace lbpkit::wire::lbp {

// Bits 7..6 of every command header (manual: LBP DATA READ/WRITE/COMMAND,
// RPC COMMANDS, LOCAL LBP COMMANDS).
enum class CommandType : std::uint8_t {
  Undefined = 0,  // 00b: not a command; the parser skips to the next gap
  Data = 1,       // 01b: data read/write
  Rpc = 2,        // 10b: RPC 0..63
  Local = 3,      // 11b: local read (0xC0..0xDF) or write (0xE0..0xFF)
};

constexpr CommandType commandType(std::uint8_t header) {
  return static_cast<CommandType>(header >> 6);
}

// The data read/write header: 0 1 WR RID AI AS DS1 DS0.
struct DataCommand {
  static constexpr std::uint8_t kType = 0x40;
  static constexpr std::uint8_t kWrite = 0x20;            // WR
  static constexpr std::uint8_t kRpcIncludesData = 0x10;  // RID (only inside RPC lists)
  static constexpr std::uint8_t kAutoInc = 0x08;          // AI
  static constexpr std::uint8_t kAddressSize = 0x04;      // AS: 1 = two address bytes follow

  bool write = false;
  bool rpcIncludesData = false;
  bool autoInc = false;
  bool hasAddress = false;
  std::uint8_t dataSize = 1;  // 1, 2, 4 or 8 bytes (DS = 0..3)

  static constexpr DataCommand decode(std::uint8_t header) {
    return DataCommand{(header & kWrite) != 0, (header & kRpcIncludesData) != 0, (header & kAutoInc) != 0,
                       (header & kAddressSize) != 0, static_cast<std::uint8_t>(1U << (header & 3U))};
  }
  [[nodiscard]] constexpr std::uint8_t encode() const {
    std::uint8_t ds = dataSize >= 8 ? 3 : dataSize >= 4 ? 2 : dataSize >= 2 ? 1 : 0;
    return static_cast<std::uint8_t>(kType | (write ? kWrite : 0) | (rpcIncludesData ? kRpcIncludesData : 0) |
                                     (autoInc ? kAutoInc : 0) | (hasAddress ? kAddressSize : 0) | ds);
  }
  // Bytes of the command after the header, before the CRC, when sent on the wire.
  [[nodiscard]] constexpr unsigned streamBytes() const {
    return (hasAddress ? 2U : 0U) + (write && !rpcIncludesData ? dataSize : 0U);
  }
};

// Convenience encoders used by hosts and tests.
constexpr std::uint8_t readHeader(std::uint8_t size, bool address, bool autoInc = false) {
  return DataCommand{false, false, autoInc, address, size}.encode();
}
constexpr std::uint8_t writeHeader(std::uint8_t size, bool address, bool autoInc = false) {
  return DataCommand{true, false, autoInc, address, size}.encode();
}

// LOCAL LBP READ COMMANDS (all return one byte). Read at 0xC0+n.
namespace local_read {
inline constexpr std::uint8_t kUnitAddress = 0xC0;
inline constexpr std::uint8_t kStatus = 0xC1;
inline constexpr std::uint8_t kCrcEnable = 0xC2;
inline constexpr std::uint8_t kCrcErrorCount = 0xC3;
inline constexpr std::uint8_t kRemoteSwMode = 0xC6;   // LBP.INC
inline constexpr std::uint8_t kClearFault = 0xC7;     // LBP.INC: reads false when done
inline constexpr std::uint8_t kRpcMemEnable = 0xCA;
inline constexpr std::uint8_t kCommandTimeout = 0xCB;  // tenths of a character time
inline constexpr std::uint8_t kNonVolatile = 0xCC;     // LBP.INC
inline constexpr std::uint8_t kCardName0 = 0xD0;       // 0xD0..0xD3
inline constexpr std::uint8_t kCapability = 0xD4;      // LBP.INC
inline constexpr std::uint8_t kSwRevision = 0xD5;      // LBP.INC
inline constexpr std::uint8_t kHwMode = 0xD6;          // LBP.INC
inline constexpr std::uint8_t kFaultStatus = 0xD7;     // LBP.INC
inline constexpr std::uint8_t kAddressLow = 0xD8;
inline constexpr std::uint8_t kAddressHigh = 0xD9;
inline constexpr std::uint8_t kVersion = 0xDA;
inline constexpr std::uint8_t kUnitId = 0xDB;
inline constexpr std::uint8_t kRpcPitch = 0xDC;
inline constexpr std::uint8_t kRpcSizeLow = 0xDD;
inline constexpr std::uint8_t kRpcSizeHigh = 0xDE;
inline constexpr std::uint8_t kCookie = 0xDF;
}  // namespace local_read

// LOCAL LBP WRITE COMMANDS (one data byte each, except 0xFF). Written at 0xE0+n.
namespace local_write {
inline constexpr std::uint8_t kStatus = 0xE1;  // 0 clears errors
inline constexpr std::uint8_t kCrcEnable = 0xE2;
inline constexpr std::uint8_t kCrcErrorCount = 0xE3;
inline constexpr std::uint8_t kRemoteSwMode = 0xE6;  // LBP.INC
inline constexpr std::uint8_t kClearFault = 0xE7;    // LBP.INC: write true to clear faults
inline constexpr std::uint8_t kRpcMemEnable = 0xEA;
inline constexpr std::uint8_t kCommandTimeout = 0xEB;
inline constexpr std::uint8_t kNonVolatile = 0xEC;  // LBP.INC
inline constexpr std::uint8_t kLeds = 0xF7;
inline constexpr std::uint8_t kAddressLow = 0xF8;
inline constexpr std::uint8_t kAddressHigh = 0xF9;
inline constexpr std::uint8_t kAddToAddress = 0xFA;
inline constexpr std::uint8_t kUnitId = 0xFD;
inline constexpr std::uint8_t kResetProcessor = 0xFE;  // only when the data byte is 0x5A
inline constexpr std::uint8_t kResetParser = 0xFF;     // no data, no CRC
}  // namespace local_write

// LBP status bits (manual: LOCAL LBP READ COMMANDS, 0xC1).
namespace status {
inline constexpr std::uint8_t kCrcError = 0x01;
inline constexpr std::uint8_t kWatchdogTimeout = 0x08;
inline constexpr std::uint8_t kBufferOverflow = 0x10;
inline constexpr std::uint8_t kInvalidWrite = 0x20;
inline constexpr std::uint8_t kCommandTimeout = 0x40;
// Bit names, bit 0 first ("" where the manual names no bit).
inline constexpr std::array<std::string_view, 8> kNames = {
    "CRCError", "", "", "WatchdogTimeoutError", "BufferOverflowError", "InvalidWriteError", "CommandTimeoutError", ""};
}  // namespace status

// Capability bits at 0xD4 and non-volatile access values at 0xCC (LBP.INC).
namespace capability {
inline constexpr std::uint8_t kCrc = 0x01;
inline constexpr std::uint8_t kEeprom = 0x04;
inline constexpr std::uint8_t kFlash = 0x08;
}  // namespace capability
namespace nonvolatile {
inline constexpr std::uint8_t kNone = 0x00;
inline constexpr std::uint8_t kEeprom = 0x01;
inline constexpr std::uint8_t kFlash = 0x02;
}  // namespace nonvolatile

// The program flash, with non-volatile access set to flash (LBP.INC:
// LBPFLASHOFFSET, LBPFLASHERASESIZE, LBPFLASHWRITESIZE, LBPFLASHCOMMIT,
// LBPFLASHERASE, LBPFLASHWRITE). The sizes read as powers of two
// (LinuxCNC's setsserial: 1 << the byte read).
namespace flash {
inline constexpr std::uint16_t kOffset = 0x8000;     // 32 bits: where the next erase or write goes
inline constexpr std::uint16_t kEraseSize = 0x8004;  // log2 of the erase block's bytes
inline constexpr std::uint16_t kWriteSize = 0x8005;  // log2 of the write page's bytes
inline constexpr std::uint16_t kCommit = 0x8007;     // write kErase or kWrite: done at kOffset
inline constexpr std::uint8_t kErase = 0xFE;
inline constexpr std::uint8_t kWrite = 0xFD;
}  // namespace flash

inline constexpr std::uint8_t kCookie = 0x5A;
inline constexpr std::uint8_t kResetKey = 0x5A;

// The special RPCs every SSLBP remote implements (the manual contradicts
// itself between SPECIAL RPCS and SSERIAL REMOTE RPCS; the firmware and
// LinuxCNC settle it: docs/protocol-facts.md#special-rpcs).
namespace special_rpc {
inline constexpr std::uint8_t kDiscovery = 0xBB;    // RXSize, TXSize, PTOCP, GTOCP
inline constexpr std::uint8_t kUnitNumber = 0xBC;   // 4 bytes, LSB first
inline constexpr std::uint8_t kProcessData = 0xBD;  // TX data in; fault byte + RX data out
}  // namespace special_rpc

inline constexpr std::uint8_t kRpcCommandBase = 0x80;
inline constexpr std::uint8_t kRpcPitch = 8;  // manual: RPC COMMANDS, "RPCPitch is 0x8 bytes"

// One asynchronous serial character: start bit, 8 data bits, stop bit
// (manual: LBP, FRAMING; command timeouts count in these).
inline constexpr int kBitsPerCharacter = 10;

}  // namespace lbpkit::wire::lbp
