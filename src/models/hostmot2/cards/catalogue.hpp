// SPDX-License-Identifier: MIT
// The Mesa Ethernet cards a 7I77 is connected to, and the firmwares lbpkit
// mirrors on them (docs/cards.md): what hm2_eth and mesaflash identify each
// card by (its LBP16 board name), its IDROM header and connectors, and per
// firmware the module list (IDROM order) and pinout. A firmware's modules are
// data here; HostMot2Card builds them from the list.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "hostmot2/idrom.hpp"

namespace lbpkit::model::hm2::cards {

// What sits on the connectors, as the firmware's PIN file lays it out.
enum class Pinout : std::uint8_t {
  // PIN_7I77x2_34.vhd: a 7I77 on each of two 17-pin connectors (12 muxed
  // counters, SSerial channels 0..5).
  SevenI77x2,
  // One 7I77 on IO0..16, IO17..33 plain GPIO: lbpkit's own, no Mesa file.
  SevenI77Gpio,
  // PIN_7I77_7I76_34.vhd: a 7I77 on IO0..16, a 7I76 (5 StepGens, SSerial
  // channels 3 and 4, a muxed counter pair for its spindle encoder) on IO17..33.
  SevenI77SevenI76,
  // The 7I96S's own step/dir, encoder, RS-422 and spindle PWM on TB1/TB2, a
  // 7I77 on P1 (7i96s_7i77d; docs/cards.md says what it is built from).
  SevenI96SSevenI77,
  // PIN_7I77_72.vhd: a 7I77 on IO0..16 of a 72-pin card, the rest GPIO.
  SevenI77Of72,
};

// The modules a card can be built with.
enum class Part : std::uint8_t {
  Dpll,
  Watchdog,
  IoPort,
  StepGen,
  MuxedQCount,
  MuxedQCountSel,
  SSerial,
  PwmGen,
  InM,
  Ssr,
  OutM,
  Led,
};
[[nodiscard]] std::string_view partName(Part part);

// One IDROM module record's worth: which module, how many instances
// (IOPort: ports; SSerial: channels of its one instance; InM: inputs of its
// one instance; LED: LEDs).
struct ModuleEntry {
  Part part;
  std::uint8_t count;
};

// Where a 7I77 sits in a firmware: its connector, its field I/O processor's
// SSerial channel (the analog processor's is the next, TB6's the one after),
// its first muxed counter, and its ENCMUX pin's unit byte.
struct SevenI77Slot {
  std::uint8_t port;
  std::uint8_t firstChannel;
  std::uint8_t firstCounter;
  std::uint8_t selectUnit;
};

struct Firmware {
  Pinout pinout;
  std::string_view name;     // `pinout = "..."` in the sim's TOML
  std::string_view bitfile;  // Mesa's file name for it ("" for lbpkit's own)
  std::string_view source;   // the facts it follows (docs/cards.md)
  std::span<const ModuleEntry> modules;  // IDROM order
  std::span<const SevenI77Slot> sevenI77s;  // the first always carries a 7I77; the others may
  // Every I/O pin's descriptor: `io` (ports x width) comes all GPIO.
  void (*pins)(std::span<PinDescriptor> io);
};

// What a card's LBP16 processor says of its FPGA and configuration flash
// (docs/cards.md#lbp16-per-card): what mesaflash's --verbose, --write,
// --verify and --reload meet.
enum class FpgaFamily : std::uint8_t {
  Xilinx,  // Spartan-6: a boot block at 0, the firmware at the flash's user area; reload through ICAP (IPROG)
  Efinix,  // Trion T20: no boot block; reload by the configuration register's image select and start bits
};
struct Lbp16Details {
  FpgaFamily family = FpgaFamily::Xilinx;
  // Space 3's ID register (0x8): mesaflash reads its low byte as the size
  // code (0x14: 16 Mbit) and puts the firmware at that size's user area.
  std::uint32_t flashId = 0x00164014;
  std::uint32_t flashBytes = 2 * 1024 * 1024;
};

struct Card {
  std::string_view name;     // LBP16 board name (space 7): mesaflash --device, lbpkit sim --card
  std::string_view halName;  // hm2_eth's board name: its pins are hm2_<halName>.0.*
  BoardIdentity idrom;       // the IDROM header (boardName is the IDROM's, e.g. MESA7I96 on a 7I96S)
  std::array<std::string_view, 4> connectors;  // per I/O port, as mesaflash names them
  std::string_view fpga;     // mesaflash's FPGA part
  unsigned leds = 4;
  std::span<const Firmware> firmwares;  // the first is the default
  Lbp16Details lbp16{};
};

// Every card lbpkit models; the 7I92 first (the default).
[[nodiscard]] std::span<const Card> all();
[[nodiscard]] const Card& defaultCard();
// By name, any case ("7i96s"); nullptr when unknown.
[[nodiscard]] const Card* find(std::string_view name);
// "7I92, 7I92T, 7I96S, 7I80HD-25": for messages.
[[nodiscard]] std::string names();
// The card's firmware with that pinout, or by its TOML name; nullptr when
// the card has none such.
[[nodiscard]] const Firmware* firmware(const Card& card, Pinout pinout);
[[nodiscard]] const Firmware* firmware(const Card& card, std::string_view name);
// The SSerial channel of the 7I76's field I/O processor on a firmware with a
// 7I76 (PIN_7I77_7I76_34.vhd: channel 3; its expansion port is channel 4);
// none on the others.
[[nodiscard]] std::optional<unsigned> sevenI76Channel(const Firmware& firmware);
// "\"7I77x2\", \"7I77+GPIO\"": the card's firmware names, for messages.
[[nodiscard]] std::string firmwareNames(const Card& card);

}  // namespace lbpkit::model::hm2::cards
