// SPDX-License-Identifier: MIT
#include "hostmot2/cards/catalogue.hpp"

#include <algorithm>
#include <cctype>

#include "hostmot2/inm.hpp"
#include "hostmot2/outm.hpp"
#include "hostmot2/ssr.hpp"

namespace lbpkit::model::hm2::cards {

namespace {

using namespace pincode;

void place(std::span<PinDescriptor> io, unsigned first, std::span<const PinDescriptor> pins) {
  std::copy(pins.begin(), pins.end(), io.begin() + first);
}

// PIN_7I77x2_34.vhd: the second connector's ENCMUX has unit 6.
void sevenI77x2Pins(std::span<PinDescriptor> io) {
  place(io, 0, sevenI77Pins(0, 0, 0));
  place(io, 17, sevenI77Pins(3, 3, 6));
}

void sevenI77GpioPins(std::span<PinDescriptor> io) { place(io, 0, sevenI77Pins(0, 0, 0)); }

// PIN_7I77_7I76_34.vhd: the 7I76 on IO17..33 with StepGens 0..4, SSerial
// channels 3 (its field I/O) and 4 (its expansion port), and muxed counter
// unit 3 (counters 6 and 7) for its spindle encoder.
constexpr unsigned kSevenI76Channel = 3;
void sevenI77SevenI76Pins(std::span<PinDescriptor> io) {
  place(io, 0, sevenI77Pins(0, 0, 0));
  place(io, 17, sevenI76Pins(0, kSevenI76Channel, 3));
}

// The 7I96S: TB3 (IO0..16) as LinuxCNC's pncconf describes every 7I96S
// firmware (private_data.py, 7i96s_d): IN0..IN10 InM inputs 0..10, OUT0..OUT3
// SSR outputs 0..3, OUT4 and OUT5 OutM outputs 4 and 5 (the HAL names
// public configurations use: inm.00.input-NN, ssr.00.out-00..03,
// outm.00.out-04..05; secondary pins as inm.c, ssr.c and outm.c decode them:
// input n is pin n + 1, output n pin 0x81 + n). TB1/TB2 (IO17..33) as
// pncconf's 7i96s_d too: Step then Dir of StepGens 0..4, the encoder's A, B
// and index, the RS-422 port's RX, TX and TX enable (SSerial channel 3 here:
// the 7I77 takes 0..2, as configurations name it, hm2_7i96s.0.7i77.0.0), the
// spindle PWM; P1 (IO34..50) the 7I77. The TB2 encoder is muxed counter unit
// 3 (counters 6 and 7), as the 7I76's is in PIN_7I77_7I76_34.vhd: LinuxCNC's
// hostmot2 refuses a firmware with both a QCount and a MuxedQCount module
// (encoder.c: "duplicate Module Descriptor").
constexpr unsigned kSevenI96SInputs = 11;
constexpr unsigned kSevenI96SSsrOutputs = 4;
constexpr unsigned kSevenI96SOutMOutputs = 2;
void sevenI96SSevenI77Pins(std::span<PinDescriptor> io) {
  std::array<PinDescriptor, 17> tb3{};
  unsigned at = 0;
  for (unsigned n = 0; n < kSevenI96SInputs; ++n)
    tb3[at++] = PinDescriptor{static_cast<std::uint8_t>(kInMInput + n), InM::kKind.tag, 0};
  for (unsigned n = 0; n < kSevenI96SSsrOutputs; ++n)
    tb3[at++] = PinDescriptor{static_cast<std::uint8_t>(kSsrOut + n), Ssr::kKind.tag, 0};
  for (unsigned n = kSevenI96SSsrOutputs; n < kSevenI96SSsrOutputs + kSevenI96SOutMOutputs; ++n)
    tb3[at++] = PinDescriptor{static_cast<std::uint8_t>(kOutMOut + n), OutM::kKind.tag, 0};
  place(io, 0, tb3);
  std::array<PinDescriptor, 17> tb{};
  for (std::uint8_t n = 0; n < 5; ++n) {
    tb[2U * n] = PinDescriptor{kStep, tag::kStepGen, n};
    tb[2U * n + 1] = PinDescriptor{kDir, tag::kStepGen, n};
  }
  tb[10] = PinDescriptor{kQcA, tag::kMuxedQCount, 3};
  tb[11] = PinDescriptor{kQcB, tag::kMuxedQCount, 3};
  tb[12] = PinDescriptor{kQcIdx, tag::kMuxedQCount, 3};
  constexpr std::uint8_t kChannel = 3;
  tb[13] = PinDescriptor{static_cast<std::uint8_t>(kSsRx + kChannel + 1), tag::kSSerial, 0};
  tb[14] = PinDescriptor{static_cast<std::uint8_t>(kSsTx + kChannel + 1), tag::kSSerial, 0};
  tb[15] = PinDescriptor{static_cast<std::uint8_t>(kSsTxEn + kChannel + 1), tag::kSSerial, 0};
  tb[16] = PinDescriptor{kPwm, tag::kPwm, 0};
  place(io, 17, tb);
  place(io, 34, sevenI77Pins(0, 0, 0));
}

// PIN_7I77_72.vhd: the 7I77 on IO0..16 of the first 24-pin connector.
void sevenI77Of72Pins(std::span<PinDescriptor> io) { place(io, 0, sevenI77Pins(0, 0, 0)); }

using P = Part;

// The firmwares' module lists, in their PIN files' order.
constexpr ModuleEntry kSevenI77x2[] = {{P::Watchdog, 1}, {P::IoPort, 2},         {P::MuxedQCount, 12},
                                       {P::MuxedQCountSel, 1}, {P::SSerial, 6}, {P::Led, 4}};
constexpr ModuleEntry kSevenI77Gpio[] = {{P::Watchdog, 1}, {P::IoPort, 2},         {P::MuxedQCount, 6},
                                         {P::MuxedQCountSel, 1}, {P::SSerial, 3}, {P::Led, 4}};
constexpr ModuleEntry kSevenI77SevenI76[] = {{P::Watchdog, 1},       {P::IoPort, 2},  {P::MuxedQCount, 8},
                                             {P::MuxedQCountSel, 1}, {P::SSerial, 5}, {P::StepGen, 5},
                                             {P::Led, 4}};
// Mesa's "d" firmwares for the Efinix cards carry the HM2DPLL first (as
// PIN_7I76E_51.vhd does; the 7I96S's readhmid lists it first).
constexpr ModuleEntry kSevenI77x2D[] = {{P::Dpll, 1},        {P::Watchdog, 1},       {P::IoPort, 2},
                                        {P::MuxedQCount, 12}, {P::MuxedQCountSel, 1}, {P::SSerial, 6},
                                        {P::Led, 4}};
constexpr ModuleEntry kSevenI77SevenI76D[] = {{P::Dpll, 1},       {P::Watchdog, 1},       {P::IoPort, 2},
                                              {P::MuxedQCount, 8}, {P::MuxedQCountSel, 1}, {P::SSerial, 5},
                                              {P::StepGen, 5},     {P::Led, 4}};
constexpr ModuleEntry kSevenI96SSevenI77[] = {
    {P::Dpll, 1},    {P::Watchdog, 1}, {P::IoPort, 3},          {P::StepGen, 5},
    {P::MuxedQCount, 8}, {P::MuxedQCountSel, 1}, {P::SSerial, 4}, {P::PwmGen, 1},
    {P::InM, kSevenI96SInputs}, {P::Ssr, 1}, {P::OutM, 1}, {P::Led, 4}};
constexpr ModuleEntry kSevenI77Of72[] = {{P::Watchdog, 1}, {P::IoPort, 3},         {P::MuxedQCount, 6},
                                         {P::MuxedQCountSel, 1}, {P::SSerial, 3}, {P::Led, 4}};

constexpr SevenI77Slot kFirstOnly[] = {{0, 0, 0, 0}};
constexpr SevenI77Slot kTwo[] = {{0, 0, 0, 0}, {1, 3, 6, 6}};
constexpr SevenI77Slot kOnP1Of7I96S[] = {{2, 0, 0, 0}};

constexpr Firmware k7I92Firmwares[] = {
    {Pinout::SevenI77x2, "7I77x2", "7i92_7i77x2", "PIN_7I77x2_34.vhd", kSevenI77x2, kTwo, sevenI77x2Pins},
    {Pinout::SevenI77Gpio, "7I77+GPIO", "", "lbpkit's own: PIN_7I77x2_34.vhd's first connector, GPIO on the second",
     kSevenI77Gpio, kFirstOnly, sevenI77GpioPins},
    {Pinout::SevenI77SevenI76, "7I77+7I76", "7i92_7i77_7i76", "PIN_7I77_7I76_34.vhd", kSevenI77SevenI76, kFirstOnly,
     sevenI77SevenI76Pins},
};
constexpr Firmware k7I92TFirmwares[] = {
    {Pinout::SevenI77SevenI76, "7I77+7I76", "7i92t_7i77_7i76d", "PIN_7I77_7I76_34.vhd with the HM2DPLL",
     kSevenI77SevenI76D, kFirstOnly, sevenI77SevenI76Pins},
    {Pinout::SevenI77x2, "7I77x2", "7i92t_7i77x2d", "PIN_7I77x2_34.vhd with the HM2DPLL", kSevenI77x2D, kTwo,
     sevenI77x2Pins},
};
constexpr Firmware k7I96SFirmwares[] = {
    {Pinout::SevenI96SSevenI77, "7I96S+7I77", "7i96s_7i77d",
     "the 7I96S's TB1/TB2 as pncconf's 7i96s_d, the 7I77 on P1 as PIN_7I77x2_34.vhd's first connector",
     kSevenI96SSevenI77, kOnP1Of7I96S, sevenI96SSevenI77Pins},
};
constexpr Firmware k7I80HDFirmwares[] = {
    {Pinout::SevenI77Of72, "7I77", "", "PIN_7I77_72.vhd on i80hd_x25card.vhd", kSevenI77Of72, kFirstOnly,
     sevenI77Of72Pins},
};

// IDROM headers: the 7I92's as lbpkit always had it; the Efinix T20 cards'
// FPGA size 20 and 256 pins, clocks 100/200 MHz, and the 7I96S calling
// itself MESA7I96 (a 7I96S's readhmid; LinuxCNC's pncconf tells the two apart
// by the 20 KGates); the 7I80HD-25 from i80hd_x25card.vhd and IDROMConst.vhd
// (ClockLow80, ClockHigh80).
//
// LBP16 details: every card a 16 Mbit flash (size code 0x14). The 7I92's is
// a W25Q16 (Mesa, LinuxCNC forum); on a real 7I96S mesaflash verifies from
// 0x100000, the user area it computes for size code 0x14 (eeprom.c
// eeprom_calc_user_space), so its flash reports 16 Mbit too; the 7I92T (the
// 7I96S's FPGA) and the 7I80HD-25 (a Spartan-6 LX25's bitstream fits the 1 MB
// user area) are lbpkit's inference. Which FPGA family: mesaflash's
// eth_boards.c (FPGA_TYPE_EFINIX for 7I92T and 7I96S).
constexpr Lbp16Details kXilinx16Mbit{FpgaFamily::Xilinx, 0x00164014, 2 * 1024 * 1024};
constexpr Lbp16Details kEfinix16Mbit{FpgaFamily::Efinix, 0x00164014, 2 * 1024 * 1024};
constexpr Card kCards[] = {
    {"7I92", "7i92", BoardIdentity{"MESA7I92", 9, 144, 2, 17, 100'000'000, 200'000'000}, {"P2", "P1", "", ""},
     "6slx9tqg144", 4, k7I92Firmwares, kXilinx16Mbit},
    {"7I92T", "7i92", BoardIdentity{"MESA7I92", 20, 256, 2, 17, 100'000'000, 200'000'000}, {"P2", "P1", "", ""},
     "T20F256", 4, k7I92TFirmwares, kEfinix16Mbit},
    {"7I96S", "7i96s", BoardIdentity{"MESA7I96", 20, 256, 3, 17, 100'000'000, 200'000'000},
     {"TB3", "TB1/TB2", "P1", ""}, "T20F256", 4, k7I96SFirmwares, kEfinix16Mbit},
    {"7I80HD-25", "7i80", BoardIdentity{"MESA7I80", 25, 256, 3, 24, 100'000'000, 200'000'000}, {"P1", "P2", "P3", ""},
     "6slx25ftg256", 4, k7I80HDFirmwares, kXilinx16Mbit},
};

bool sameName(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::toupper(static_cast<unsigned char>(x)) == std::toupper(static_cast<unsigned char>(y));
         });
}

std::string quotedList(auto&& names) {
  std::string s;
  for (std::string_view n : names) s += (s.empty() ? "\"" : ", \"") + std::string(n) + "\"";
  return s;
}

}  // namespace

std::string_view partName(Part part) {
  switch (part) {
    case Part::Dpll: return "HM2DPLL";
    case Part::Watchdog: return "WatchDog";
    case Part::IoPort: return "IOPort";
    case Part::StepGen: return "StepGen";
    case Part::MuxedQCount: return "MuxedQCount";
    case Part::MuxedQCountSel: return "MuxedQCountSel";
    case Part::SSerial: return "SSerial";
    case Part::PwmGen: return "PWMGen";
    case Part::InM: return "InM";
    case Part::Ssr: return "SSR";
    case Part::OutM: return "OutM";
    case Part::Led: return "LED";
  }
  return "unknown";
}

std::span<const Card> all() { return kCards; }
const Card& defaultCard() { return kCards[0]; }

const Card* find(std::string_view name) {
  for (const auto& c : kCards)
    if (sameName(c.name, name)) return &c;
  return nullptr;
}

std::string names() {
  std::string s;
  for (const auto& c : kCards) s += (s.empty() ? "" : ", ") + std::string(c.name);
  return s;
}

const Firmware* firmware(const Card& card, Pinout pinout) {
  for (const auto& f : card.firmwares)
    if (f.pinout == pinout) return &f;
  return nullptr;
}

const Firmware* firmware(const Card& card, std::string_view name) {
  for (const auto& f : card.firmwares)
    if (sameName(f.name, name)) return &f;
  return nullptr;
}

std::optional<unsigned> sevenI76Channel(const Firmware& firmware) {
  if (firmware.pinout == Pinout::SevenI77SevenI76) return kSevenI76Channel;
  return std::nullopt;
}

std::string firmwareNames(const Card& card) {
  std::array<std::string_view, 8> n{};
  std::size_t k = 0;
  for (const auto& f : card.firmwares)
    if (k < n.size()) n[k++] = f.name;
  return quotedList(std::span<const std::string_view>(n.data(), k));
}

}  // namespace lbpkit::model::hm2::cards
