// SPDX-License-Identifier: MIT
// HostMot2: the identification area, the IDROM and its module and pin
// descriptors (docs/protocol-facts.md#hostmot2; firmware: idrom.vhd,
// IDROMConst.vhd; LinuxCNC: hostmot2.h). The modules and their registers:
// hostmot2_modules.hpp.
#pragma once

#include <cstdint>
#include <string_view>

#include "lbpkit/wire/hostmot2_modules.hpp"

namespace lbpkit::wire::hm2 {

// The identification area and where the IDROM is.
namespace idrom {
inline constexpr std::uint16_t kCookieAddress = 0x0100;
inline constexpr std::uint32_t kCookie = 0x55AACAFE;
inline constexpr std::uint16_t kConfigName = 0x0104;  // "HOSTMOT2", two words
inline constexpr std::uint16_t kIdromPointer = 0x010C;
inline constexpr std::uint32_t kIdromType = 3;
// Where lbpkit's cards put the IDROM (what kIdromPointer reads), and its size.
inline constexpr std::uint16_t kIdromAddress = 0x0400;
inline constexpr std::uint16_t kIdromBytes = 0x0400;
// The configuration name's two words: "HOST", "MOT2".
inline constexpr std::uint32_t kConfigNameHost = 0x54534F48;
inline constexpr std::uint32_t kConfigNameMot2 = 0x32544F4D;

// Byte offsets in the IDROM header.
inline constexpr unsigned kType = 0x00;
inline constexpr unsigned kOffsetToModulesField = 0x04;
inline constexpr unsigned kOffsetToPinsField = 0x08;
inline constexpr unsigned kBoardNameLow = 0x0C;
inline constexpr unsigned kBoardNameHigh = 0x10;
inline constexpr unsigned kFpgaSize = 0x14;
inline constexpr unsigned kFpgaPins = 0x18;
inline constexpr unsigned kIoPorts = 0x1C;
inline constexpr unsigned kIoWidth = 0x20;
inline constexpr unsigned kPortWidth = 0x24;
inline constexpr unsigned kClockLow = 0x28;
inline constexpr unsigned kClockHigh = 0x2C;
inline constexpr unsigned kInstanceStride0 = 0x30;
inline constexpr unsigned kInstanceStride1 = 0x34;
inline constexpr unsigned kRegisterStride0 = 0x38;
inline constexpr unsigned kRegisterStride1 = 0x3C;
// Where the module and pin descriptors start (what the Offset fields hold).
inline constexpr std::uint32_t kOffsetToModules = 0x40;
inline constexpr std::uint32_t kOffsetToPins = 0x1C0;
inline constexpr unsigned kModuleDescriptorBytes = 12;  // three words
inline constexpr unsigned kPinDescriptorBytes = 4;
}  // namespace idrom

// Pin descriptor: secondary pin code (bit 7: output), secondary tag,
// secondary unit, primary tag (always IOPort).
namespace pin {
inline constexpr std::uint8_t kOutput = 0x80;
inline constexpr std::uint8_t kCodeMask = 0x7F;
// SSerial pin codes: 0x8n TXn, 0x0n RXn, 0x9n TXENn, for channel n-1.
inline constexpr std::uint8_t kSSerialKindMask = 0xF0;
inline constexpr std::uint8_t kSSerialTxEn = 0x90;
inline constexpr std::uint8_t kSSerialTx = 0x80;
inline constexpr std::uint8_t kSSerialRx = 0x00;
inline constexpr std::uint8_t kSSerialChannelMask = 0x0F;
// MuxedQCount pin codes.
inline constexpr std::uint8_t kQCountA = 1;
inline constexpr std::uint8_t kQCountB = 2;
inline constexpr std::uint8_t kQCountIndex = 3;
inline constexpr std::uint8_t kQCountIndexMask = 4;
// MuxedQCountSel pin codes: SEL0 is 1.
inline constexpr std::uint8_t kQCountSel0 = 1;
}  // namespace pin

}  // namespace lbpkit::wire::hm2
