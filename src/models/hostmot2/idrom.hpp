// SPDX-License-Identifier: MIT
// The HostMot2 identification area and IDROM (HostMot2 regmap; idrom.vhd and
// IDROMConst.vhd; docs/protocol-facts.md#identification-area-and-idrom): what drivers read to learn the
// card, its clocks, its modules and the function of every I/O pin.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "hostmot2/module.hpp"

namespace lbpkit::model::hm2 {

namespace idrom {
// Offsets, cookie and layout are the wire's (wire::hm2::idrom), which the
// driver reads by.
// How much room the card's IDROM has.
inline constexpr unsigned kMaxModules = 32;
inline constexpr unsigned kMaxPins = 144;
inline constexpr std::size_t kWords = wire::hm2::idrom::kIdromBytes / 4;
}  // namespace idrom

// One pin descriptor: primary IOPort, and the module that can drive it.
struct PinDescriptor {
  std::uint8_t secondaryPin = 0;   // module pin code; bit 7 = output
  std::uint8_t secondaryTag = 0;   // module tag (0: GPIO only)
  std::uint8_t secondaryUnit = 0;  // module instance / unit
  [[nodiscard]] std::uint32_t word() const {
    return static_cast<std::uint32_t>(secondaryPin) | (static_cast<std::uint32_t>(secondaryTag) << 8) |
           (static_cast<std::uint32_t>(secondaryUnit) << 16) | (static_cast<std::uint32_t>(tag::kIoPort) << 24);
  }
};

struct BoardIdentity {
  std::string_view boardName = "MESA7I92";  // 8 characters: low word, high word
  std::uint32_t fpgaSize = 9;
  std::uint32_t fpgaPins = 144;
  std::uint32_t ioPorts = 2;
  std::uint32_t portWidth = 17;
  std::uint32_t clockLow = 100'000'000;
  std::uint32_t clockHigh = 200'000'000;
};

// The IDROM words (0x0400..0x07FF) for these modules and pins.
std::array<std::uint32_t, idrom::kWords> buildIdrom(const BoardIdentity& board,
                                                    std::span<const ModuleDescriptor> modules,
                                                    std::span<const PinDescriptor> pins);

// Secondary pin codes (IDROMConst.vhd; docs/protocol-facts.md#module-and-pin-descriptors):
// bit 7 set = the module drives the pin.
namespace pincode {
inline constexpr std::uint8_t kSsRx = 0x00;    // + channel + 1
inline constexpr std::uint8_t kSsTx = 0x80;    // + channel + 1
inline constexpr std::uint8_t kSsTxEn = 0x90;  // + channel + 1
inline constexpr std::uint8_t kQcA = 0x01;     // QCount and MuxedQCount
inline constexpr std::uint8_t kQcB = 0x02;
inline constexpr std::uint8_t kQcIdx = 0x03;
inline constexpr std::uint8_t kSel0 = 0x81;    // MuxedQCountSel
inline constexpr std::uint8_t kStep = 0x81;    // StepGen StepGenStepPin
inline constexpr std::uint8_t kDir = 0x82;     // StepGen StepGenDirPin
inline constexpr std::uint8_t kPwm = 0x81;     // PWMGen PWMAOutPin
inline constexpr std::uint8_t kInMInput = 0x01;  // InM: + input (inm.c; mesaflash "Input<n>")
inline constexpr std::uint8_t kSsrOut = 0x81;    // SSR: + output (ssr.c; mesaflash "Out-NN")
inline constexpr std::uint8_t kOutMOut = 0x81;   // OutM: + output (outm.c; mesaflash "Output<n>")
}  // namespace pincode

// The pins of one 7I77 on a 17-pin connector (manual: P1 HOST INTERFACE):
// IO0 SS2TXEN, IO1 SS2TX, IO2 SS2RX, IO3 SS1TX, IO4 SS1RX, IO5 SS0TX,
// IO6 SS0RX, IO7 ENCMUX, IO8..IO16 QCMUX A/B/I for pairs 01, 23, 45.
// `firstChannel` and `firstUnit` place it (0 on the first connector, 3 on
// the second); `selectUnit` is its ENCMUX pin's unit byte (0 and 6 in
// PIN_7I77x2_34.vhd).
std::array<PinDescriptor, 17> sevenI77Pins(unsigned firstChannel, unsigned firstUnit, unsigned selectUnit);

// The pins of one 7I76 on a 17-pin connector as PIN_7I77_7I76_34.vhd has it
// on IO17..33: Dir then Step of StepGens firstStepGen..+4, SSerial TX/RX of
// `channel` (field I/O) and `channel + 1` (expansion), then the spindle
// encoder's index, B and A on muxed counter unit `counterUnit`.
std::array<PinDescriptor, 17> sevenI76Pins(unsigned firstStepGen, unsigned channel, unsigned counterUnit);

}  // namespace lbpkit::model::hm2
