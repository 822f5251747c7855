// HostMot2: the identification area, the IDROM and its module and pin
// descriptors, and the module tags (docs/protocol-facts.md#hostmot2;
// firmware: idrom.vhd, IDROMConst.vhd; LinuxCNC: hostmot2.h).
#pragma once

#include <cstdint>
#include <string_view>

namespace lbpkit::wire::hm2 {

// The identification area and where the IDROM is.
namespace idrom {
inline constexpr std::uint16_t kCookieAddress = 0x0100;
inline constexpr std::uint32_t kCookie = 0x55AACAFE;
inline constexpr std::uint16_t kConfigName = 0x0104;  // "HOSTMOT2", two words
inline constexpr std::uint16_t kIdromPointer = 0x010C;
inline constexpr std::uint32_t kIdromType = 3;

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

// Module tags (GTag, IDROMConst.vhd).
namespace tag {
inline constexpr std::uint8_t kIrq = 0x01;
inline constexpr std::uint8_t kWatchdog = 0x02;
inline constexpr std::uint8_t kIoPort = 0x03;
inline constexpr std::uint8_t kQCount = 0x04;
inline constexpr std::uint8_t kStepGen = 0x05;
inline constexpr std::uint8_t kPwm = 0x06;
inline constexpr std::uint8_t kMuxedQCount = 0x0C;
inline constexpr std::uint8_t kMuxedQCountSel = 0x0D;
inline constexpr std::uint8_t kLed = 0x80;
inline constexpr std::uint8_t kSSerial = 0xC1;
}  // namespace tag

// The module's name as the firmware and LinuxCNC spell it; empty if unknown.
constexpr std::string_view moduleName(std::uint8_t t) {
  switch (t) {
    case tag::kIrq: return "IRQ";
    case tag::kWatchdog: return "WatchDog";
    case tag::kIoPort: return "IOPort";
    case tag::kQCount: return "QCount";
    case tag::kStepGen: return "StepGen";
    case tag::kPwm: return "PWM";
    case tag::kMuxedQCount: return "MuxedQCount";
    case tag::kMuxedQCountSel: return "MuxedQCountSel";
    case tag::kLed: return "LED";
    case tag::kSSerial: return "SSerial";
    default: return {};
  }
}

// Module descriptor clock tags.
inline constexpr std::uint8_t kClockLow = 1;
inline constexpr std::uint8_t kClockHigh = 2;

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

// Register blocks are 0x100 bytes apart ("Addr byte << 8"); instances and
// channels are 4 bytes apart inside a block (stride select 0) or 0x40
// (stride select 1).
inline constexpr std::uint16_t kRegisterStride = 0x100;
inline constexpr std::uint16_t kInstanceStride0 = 4;
inline constexpr std::uint16_t kInstanceStride1 = 0x40;

}  // namespace lbpkit::wire::hm2
