// SPDX-License-Identifier: MIT
// The 7I77's two LBP remotes as a host sees them: unit number types, the
// remote fault byte and the operate-mode baud rates (manual: CS REGISTER
// AFTER DOIT, NON-VOLATILE FIELD I/O PARAMETERS; docs/protocol-facts.md#7i77).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>

namespace lbpkit::wire::i7i77 {

inline constexpr std::string_view kCardName = "7I77";

// The unit number's top byte says which processor it is (as mesaflash shows).
namespace unit_type {
inline constexpr std::uint8_t kFieldIo = 0x12;
inline constexpr std::uint8_t kAnalog = 0x11;
inline constexpr unsigned kShift = 24;
}  // namespace unit_type

// Remote fault byte (CS byte 3 after DOIT, and the process data's fault byte).
namespace fault {
inline constexpr std::uint8_t kWatchdog = 0x01;
inline constexpr std::uint8_t kNoEnable = 0x02;
inline constexpr std::uint8_t kOverTemp = 0x04;
inline constexpr std::uint8_t kOverCurrent = 0x08;
inline constexpr std::uint8_t kHighVoltage = 0x10;
inline constexpr std::uint8_t kLowVoltage = 0x20;
inline constexpr std::uint8_t kIllegalMode = 0x40;
inline constexpr std::uint8_t kLbpCom = 0x80;
// Bit names as the manual spells them, bit 0 first.
inline constexpr std::array<std::string_view, 8> kNames = {"WatchdogFault",   "NoEnableFault",    "OverTempFault",
                                                          "OverCurrentFault", "HighVoltageFault", "LowVoltageFault",
                                                          "IllegalModeFault", "LBPCOMFault"};
}  // namespace fault

// Operate mode baud rates by NVBAUDRATE index (manual: OPERATE MODE BAUD RATE).
inline constexpr std::array<std::uint32_t, 12> kBaudRates = {9600,   19200,  38400,  57600,   115200,  230400,
                                                             460800, 921600, 1250000, 2500000, 5000000, 10000000};
inline constexpr std::uint8_t kDefaultBaudIndex = 9;  // 2.5 MBaud
inline constexpr std::uint32_t kSetupBaud = 115200;   // setup mode jumpers
inline constexpr std::uint16_t kDefaultWatchdogMs = 50;
// Each processor's program flash: no public source gives its size; lbpkit's
// choice (docs/protocol-facts.md#the-program-flash). A firmware image larger
// than this cannot be the processor's.
inline constexpr std::size_t kProgramFlashBytes = 32 * 1024;

}  // namespace lbpkit::wire::i7i77
