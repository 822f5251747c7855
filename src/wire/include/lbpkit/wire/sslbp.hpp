// SPDX-License-Identifier: MIT
// SSLBP, the SSerial module's firmware for LBP remotes: its COMMAND values,
// CS bits and local parameter map (docs/protocol-facts.md#sslbp; manual:
// REFERENCE INFORMATION, SSLBP; firmware: the SSLBP source).
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

#include "lbpkit/wire/hostmot2_modules.hpp"

namespace lbpkit::wire::sslbp {

// The registers (hostmot2_modules.hpp), from the module's base in register
// strides; CS and the interfaces per channel, kChannelStride bytes apart.
namespace reg {
using hm2::sserial::Register;
using enum hm2::sserial::Register;
using hm2::sserial::kInterfaces;
inline constexpr unsigned kChannelStride = hm2::kInstanceStride0;
}  // namespace reg

// COMMAND register values (manual: COMMAND REGISTER): W M R D S T T T | N..N.
namespace command {
inline constexpr std::uint32_t kIgnore = 0x80000000;  // writes with bit 31 set are ignored
inline constexpr std::uint16_t kWrite = 0x8000;
inline constexpr std::uint16_t kReset = 0x4000;  // M: hold the processor in reset
inline constexpr std::uint16_t kRequest = 0x2000;
inline constexpr std::uint16_t kDoit = 0x1000;
inline constexpr std::uint16_t kStop = 0x0800;
inline constexpr std::uint16_t kStart = 0x0900;
inline constexpr std::uint16_t kSetupStart = 0x0F00;
inline constexpr std::uint16_t kTypeMask = 0xFF00;  // the command without its channel mask / address
inline constexpr std::uint16_t kAddressMask = 0x03FF;  // local parameter address of a request
}  // namespace command

// CS register bits (manual: CS REGISTER AFTER START / AFTER DOIT).
namespace cs {
// Byte 0: local communication faults, sticky until STOP.
inline constexpr std::uint8_t kCrcError = 0x01;
inline constexpr std::uint8_t kInvalidCookie = 0x02;
inline constexpr std::uint8_t kOverrun = 0x04;
inline constexpr std::uint8_t kTimeout = 0x08;
inline constexpr std::uint8_t kExtraCharacter = 0x10;
inline constexpr std::uint8_t kSerialBreak = 0x20;
inline constexpr std::uint8_t kRemoteFault = 0x40;
inline constexpr std::uint8_t kTooManyErrors = 0x80;
inline constexpr std::array<std::string_view, 8> kLocalFaultNames = {
    "CRCError",         "InvalidCookieError", "OverrunError", "TimeoutError",
    "ExtraCharacterError", "SerialBreakError", "RemoteFault",  "TooManyErrors"};
// Byte 1: communication status.
inline constexpr std::uint8_t kStatusRemoteFault = 0x01;
inline constexpr std::uint8_t kStatusCommunicationError = 0x20;
inline constexpr std::uint8_t kStatusNoRemoteId = 0x40;
inline constexpr std::uint8_t kStatusNotReady = 0x80;
inline constexpr std::array<std::string_view, 8> kStatusNames = {
    "RemoteFault", "", "", "", "", "CommunicationError", "NoRemoteID", "CommunicationNotReady"};
// Byte 3 after DOIT: the remote's fault byte; when writing CS before
// START: the remote's software mode (REMOTE MODES).
inline constexpr unsigned kRemoteByteShift = 24;
}  // namespace cs

// Local parameters (manual: LOCAL PARAMETERS; the firmware's RAM map where
// the manual differs: its GP_INPUTS/GP_OUTPUTS at 4 and 5 are the channel
// block start 0x70 and stride 0x32).
namespace local {
inline constexpr std::uint16_t kInterfaceType = 0;   // 0x12
inline constexpr std::uint16_t kInterfaceWidth = 1;  // 8
inline constexpr std::uint16_t kMajorRev = 2;
inline constexpr std::uint16_t kMinorRev = 3;
inline constexpr std::uint16_t kChannelStart = 4;   // where the per-channel blocks start
inline constexpr std::uint16_t kChannelStride = 5;  // and how far apart they are
inline constexpr std::uint16_t kProcessorType = 6;  // 0xD8 Dumb8
inline constexpr std::uint16_t kChannels = 7;
// In each channel block.
inline constexpr std::uint16_t kBaudOffset = 0x2A;    // 32-bit baud rate
inline constexpr std::uint16_t kRxSizeOffset = 0x2E;  // sizes the discovery RPC reported
inline constexpr std::uint16_t kTxSizeOffset = 0x2F;
}  // namespace local

inline constexpr std::uint8_t kInterfaceType = 0x12;
inline constexpr std::uint8_t kProcessorTypeDumb8 = 0xD8;

}  // namespace lbpkit::wire::sslbp
