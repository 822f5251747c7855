// SPDX-License-Identifier: MIT
// The HostMot2 module map: every module kind lbpkit knows, as data. Each
// kind's tag, its names (the IDROM's and mesaflash's, and the word LinuxCNC's
// hostmot2 puts in pin names), its clock, where the firmwares here put it,
// and its registers in order: name, index (register strides from the base),
// per-instance or single, access, power-up value.
//
// The models answer at these addresses, the host library and `lbpkit decode`
// name what they see by them, the pin predictor counts modules by their
// tags, and docs/hostmot2-modules.md#the-module-map is checked against them.
// Sources per module: docs/hostmot2-modules.md and docs/protocol-facts.md
// (firmware: IDROMConst.vhd, hostmot2.vhd; LinuxCNC: hostmot2.h and one
// driver file per module).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

namespace lbpkit::wire::hm2 {

// Module tags (GTag: IDROMConst.vhd; LinuxCNC hostmot2.h HM2_GTAG_*).
namespace tag {
inline constexpr std::uint8_t kIrq = 0x01;
inline constexpr std::uint8_t kWatchdog = 0x02;
inline constexpr std::uint8_t kIoPort = 0x03;
inline constexpr std::uint8_t kQCount = 0x04;
inline constexpr std::uint8_t kStepGen = 0x05;
inline constexpr std::uint8_t kPwm = 0x06;
inline constexpr std::uint8_t kMuxedQCount = 0x0C;
inline constexpr std::uint8_t kMuxedQCountSel = 0x0D;
inline constexpr std::uint8_t kDpll = 0x1A;  // HM2DPLLTag (0x10, the older DPLLTag, is another module)
inline constexpr std::uint8_t kInM = 0x23;
inline constexpr std::uint8_t kOutM = 0x2D;
inline constexpr std::uint8_t kLed = 0x80;
inline constexpr std::uint8_t kSSerial = 0xC1;
inline constexpr std::uint8_t kSsr = 0xC3;
}  // namespace tag

// Module descriptor clock tags.
inline constexpr std::uint8_t kClockLow = 1;
inline constexpr std::uint8_t kClockHigh = 2;

// Register blocks are 0x100 bytes apart ("Addr byte << 8"); instances and
// channels are 4 bytes apart inside a block (stride select 0) or 0x40
// (stride select 1).
inline constexpr std::uint16_t kRegisterStride = 0x100;
inline constexpr std::uint16_t kInstanceStride0 = 4;
inline constexpr std::uint16_t kInstanceStride1 = 0x40;

// Where a register is repeated: once for the module (at the block's first
// word), once per instance (4 bytes apart), or once per SSerial channel of
// the module's one instance (4 bytes apart).
enum class Scope : std::uint8_t { Single, PerInstance, PerChannel };
enum class Access : std::uint8_t { ReadWrite, ReadOnly, WriteOnly };
// Whether the register is there in every firmware with the module, or only
// in those whose IDROM also has an HM2DPLL (the "d" firmwares).
enum class Presence : std::uint8_t { Always, WithDpll };

struct Register {
  std::string_view name;  // lbpkit decode's and the docs' name
  std::uint8_t index;     // register strides from the module's base
  Scope scope;
  Access access;
  // What it reads after power-up; none where that depends on the clock,
  // the pins or the time (the docs say how).
  std::optional<std::uint32_t> powerUp;
  Presence presence = Presence::Always;
};

struct ModuleKind {
  std::uint8_t tag;
  std::string_view name;      // the IDROM's name (mesaflash prints it)
  std::string_view halWord;   // LinuxCNC's word in pin names: hm2_7i92.0.<halWord>...
  std::uint8_t clock;         // kClockLow or kClockHigh
  std::uint16_t base;         // its base address in every firmware here; 0: no registers
  std::uint8_t version;       // the version the firmwares here report
  std::uint8_t idromRegisters;  // as the module descriptor counts them
  std::uint8_t strides;       // the descriptor's stride selects (high nibble: instance stride)
  std::span<const Register> registers;  // in index order; may go past idromRegisters

  // The descriptor's multiple-register mask: the registers repeated per
  // instance or channel, among those the descriptor counts.
  [[nodiscard]] constexpr std::uint32_t multipleRegisters() const {
    std::uint32_t mask = 0;
    for (const auto& r : registers)
      if (r.index < idromRegisters && r.scope != Scope::Single) mask |= 1U << r.index;
    return mask;
  }
  [[nodiscard]] constexpr std::uint16_t address(unsigned index) const {
    return static_cast<std::uint16_t>(base + index * kRegisterStride);
  }
  // The register at `index`; nullptr where the module has none.
  [[nodiscard]] constexpr const Register* at(unsigned index) const {
    for (const auto& r : registers)
      if (r.index == index) return &r;
    return nullptr;
  }
};

// --- The registers of each module, by index ---------------------------------

namespace watchdog {
enum Register : std::uint8_t { kTimer, kStatus, kReset };
inline constexpr std::uint32_t kDisarmed = 0x80000000U;  // timer bit 31
inline constexpr std::uint8_t kPetCookie = 0x5A;          // a reset write's top byte
}  // namespace watchdog

namespace ioport {
enum Register : std::uint8_t { kData, kDdr, kAltSource, kOpenDrain, kOutputInvert };
}

// QCount and MuxedQCount: the same counters and registers at their own bases.
namespace qcount {
enum Register : std::uint8_t { kCount, kControl, kTimestampDiv, kTimestamp, kRate, kTimerSelect };
}

namespace stepgen {
enum Register : std::uint8_t {
  kRate,
  kAccumulator,
  kMode,
  kDirSetup,
  kDirHold,
  kPulseWidth,
  kPulseIdle,
  kTableData,
  kTableLength,
  kMasterRate,
  kTimerSelect,
};
}

namespace pwmgen {
enum Register : std::uint8_t { kValue, kMode, kPwmRate, kPdmRate, kEnable };
}

namespace led {
enum Register : std::uint8_t { kLeds };
}

namespace sserial {
enum Register : std::uint8_t { kCommand, kData, kCs, kInterface0, kInterface1, kInterface2 };
inline constexpr unsigned kInterfaces = 3;
}

namespace dpll {
enum Register : std::uint8_t { kBaseRate, kPhase, kControl0, kControl1, kTimers12, kTimers34, kSync };
inline constexpr std::uint32_t kAccumulatorBits = 42;  // what control 1 reads in 7..0
}

namespace inm {
enum Register : std::uint8_t { kControl, kFilter, kFiltered, kRaw, kMpg };
}

namespace ssr {
enum Register : std::uint8_t { kData, kRate };
}

namespace outm {
enum Register : std::uint8_t { kData };
}

// --- The catalogue --------------------------------------------------------------

namespace detail {
using A = Access;
using S = Scope;
inline constexpr std::optional<std::uint32_t> kVaries = std::nullopt;

inline constexpr std::array<Register, 3> kWatchdogRegisters = {{
    {"timer", watchdog::kTimer, S::Single, A::ReadWrite, watchdog::kDisarmed},
    {"status", watchdog::kStatus, S::Single, A::ReadWrite, 0},
    {"reset", watchdog::kReset, S::Single, A::WriteOnly, 0},
}};
inline constexpr std::array<Register, 5> kIoPortRegisters = {{
    {"data", ioport::kData, S::PerInstance, A::ReadWrite, kVaries},  // reads the pins
    {"ddr", ioport::kDdr, S::PerInstance, A::ReadWrite, 0},
    {"alt_source", ioport::kAltSource, S::PerInstance, A::ReadWrite, 0},
    {"open_drain", ioport::kOpenDrain, S::PerInstance, A::ReadWrite, 0},
    {"output_invert", ioport::kOutputInvert, S::PerInstance, A::ReadWrite, 0},
}};
// The rate's power-up value is round(ClockLow / 16 MHz) - 2 (QCount) or
// round(ClockLow / 8 MHz) - 2 (MuxedQCount); the count and CCR show the
// inputs and the timestamp counter runs.
inline constexpr std::array<Register, 6> kQCountRegisters = {{
    {"count", qcount::kCount, S::PerInstance, A::ReadWrite, kVaries},
    {"control", qcount::kControl, S::PerInstance, A::ReadWrite, kVaries},
    {"timestamp_div", qcount::kTimestampDiv, S::Single, A::ReadWrite, 0},
    {"timestamp_count", qcount::kTimestamp, S::Single, A::ReadOnly, kVaries},
    {"filter_rate", qcount::kRate, S::Single, A::ReadWrite, kVaries},
    {"timer_select", qcount::kTimerSelect, S::Single, A::ReadWrite, 0, Presence::WithDpll},
}};
inline constexpr std::array<Register, 11> kStepGenRegisters = {{
    {"rate", stepgen::kRate, S::PerInstance, A::ReadWrite, 0},
    {"accumulator", stepgen::kAccumulator, S::PerInstance, A::ReadWrite, 0},
    {"mode", stepgen::kMode, S::PerInstance, A::ReadWrite, 0},
    {"dir_setup", stepgen::kDirSetup, S::PerInstance, A::ReadWrite, 0},
    {"dir_hold", stepgen::kDirHold, S::PerInstance, A::ReadWrite, 0},
    {"pulse_width", stepgen::kPulseWidth, S::PerInstance, A::ReadWrite, 0},
    {"pulse_idle", stepgen::kPulseIdle, S::PerInstance, A::ReadWrite, 0},
    {"table_data", stepgen::kTableData, S::PerInstance, A::ReadWrite, 0},
    {"table_length", stepgen::kTableLength, S::PerInstance, A::ReadWrite, 0},
    {"master_rate", stepgen::kMasterRate, S::Single, A::ReadWrite, 0},
    {"timer_select", stepgen::kTimerSelect, S::Single, A::ReadWrite, 0},
}};
inline constexpr std::array<Register, 5> kPwmGenRegisters = {{
    {"value", pwmgen::kValue, S::PerInstance, A::ReadWrite, 0},
    {"mode", pwmgen::kMode, S::PerInstance, A::ReadWrite, 0},
    {"pwm_rate", pwmgen::kPwmRate, S::Single, A::ReadWrite, 0},
    {"pdm_rate", pwmgen::kPdmRate, S::Single, A::ReadWrite, 0},
    {"enable", pwmgen::kEnable, S::Single, A::ReadWrite, 0},
}};
inline constexpr std::array<Register, 1> kLedRegisters = {{
    {"leds", led::kLeds, S::Single, A::WriteOnly, 0},
}};
// COMMAND and DATA per instance (0x40 apart), the rest per channel. DATA
// reads 0xAA once SSLBP's init has run; CS shows each channel's state.
inline constexpr std::array<Register, 6> kSSerialRegisters = {{
    {"command", sserial::kCommand, S::Single, A::ReadWrite, 0},
    {"data", sserial::kData, S::Single, A::ReadWrite, 0xAA},
    {"cs", sserial::kCs, S::PerChannel, A::ReadWrite, kVaries},
    {"interface0", sserial::kInterface0, S::PerChannel, A::ReadWrite, kVaries},
    {"interface1", sserial::kInterface1, S::PerChannel, A::ReadWrite, kVaries},
    {"interface2", sserial::kInterface2, S::PerChannel, A::ReadWrite, kVaries},
}};
inline constexpr std::array<Register, 7> kDpllRegisters = {{
    {"base_rate", dpll::kBaseRate, S::Single, A::ReadWrite, 0},
    {"phase", dpll::kPhase, S::Single, A::ReadWrite, 0},
    {"control0", dpll::kControl0, S::Single, A::ReadWrite, 0},
    {"control1", dpll::kControl1, S::Single, A::ReadWrite, dpll::kAccumulatorBits},
    {"timers12", dpll::kTimers12, S::Single, A::ReadWrite, 0},
    {"timers34", dpll::kTimers34, S::Single, A::ReadWrite, 0},
    {"sync", dpll::kSync, S::Single, A::ReadWrite, 0},
}};
// The control register's MaxBit (4..0) is the instance's input count less
// one; filtered and raw show the pins.
inline constexpr std::array<Register, 5> kInMRegisters = {{
    {"control", inm::kControl, S::PerInstance, A::ReadWrite, kVaries},
    {"filter", inm::kFilter, S::PerInstance, A::ReadWrite, 0},
    {"filtered", inm::kFiltered, S::PerInstance, A::ReadOnly, kVaries},
    {"raw", inm::kRaw, S::PerInstance, A::ReadOnly, kVaries},
    {"mpg", inm::kMpg, S::PerInstance, A::ReadWrite, 0},
}};
inline constexpr std::array<Register, 2> kSsrRegisters = {{
    {"data", ssr::kData, S::PerInstance, A::ReadWrite, 0},
    {"rate", ssr::kRate, S::PerInstance, A::ReadWrite, 0},
}};
inline constexpr std::array<Register, 1> kOutMRegisters = {{
    {"data", outm::kData, S::PerInstance, A::ReadWrite, 0},
}};
}  // namespace detail

// Tag, name, LinuxCNC's word, clock, base, version, IDROM register count,
// strides, registers.
inline constexpr ModuleKind kWatchdog{tag::kWatchdog, "WatchDog", "watchdog", kClockLow, 0x0C00, 0, 3, 0x00,
                                      detail::kWatchdogRegisters};
inline constexpr ModuleKind kIoPort{tag::kIoPort, "IOPort", "ioport", kClockLow, 0x1000, 0, 5, 0x00,
                                    detail::kIoPortRegisters};
inline constexpr ModuleKind kQCount{tag::kQCount, "QCount", "encoder", kClockLow, 0x3000, 2, 5, 0x00,
                                    detail::kQCountRegisters};
inline constexpr ModuleKind kStepGen{tag::kStepGen, "StepGen", "stepgen", kClockLow, 0x2000, 2, 10, 0x00,
                                     detail::kStepGenRegisters};
inline constexpr ModuleKind kPwmGen{tag::kPwm, "PWM", "pwmgen", kClockHigh, 0x4000, 0, 5, 0x00,
                                    detail::kPwmGenRegisters};
inline constexpr ModuleKind kMuxedQCount{tag::kMuxedQCount, "MuxedQCount", "encoder", kClockLow, 0x3500, 3, 5, 0x00,
                                         detail::kQCountRegisters};
inline constexpr ModuleKind kMuxedQCountSel{tag::kMuxedQCountSel, "MuxedQCountSel", "encoder", kClockLow, 0, 0, 0, 0x00,
                                            {}};
inline constexpr ModuleKind kLed{tag::kLed, "LED", "led", kClockLow, 0x0200, 0, 1, 0x00, detail::kLedRegisters};
inline constexpr ModuleKind kSSerial{tag::kSSerial, "SSerial", "sserial", kClockLow, 0x5A00, 0, 6, 0x10,
                                     detail::kSSerialRegisters};
inline constexpr ModuleKind kDpll{tag::kDpll, "HM2DPLL", "dpll", kClockLow, 0x7000, 0, 7, 0x00,
                                  detail::kDpllRegisters};
inline constexpr ModuleKind kInM{tag::kInM, "InM", "inm", kClockLow, 0x8500, 0, 5, 0x00, detail::kInMRegisters};
inline constexpr ModuleKind kSsr{tag::kSsr, "SSR", "ssr", kClockLow, 0x7D00, 0, 2, 0x00, detail::kSsrRegisters};
inline constexpr ModuleKind kOutM{tag::kOutM, "OutM", "outm", kClockLow, 0xB000, 0, 1, 0x00, detail::kOutMRegisters};

// Every kind, in tag order.
inline constexpr std::array<const ModuleKind*, 13> kModuleKinds = {
    &kWatchdog, &kIoPort, &kQCount, &kStepGen, &kPwmGen, &kMuxedQCount, &kMuxedQCountSel,
    &kDpll,     &kInM,    &kOutM,   &kLed,     &kSSerial, &kSsr};

// The kind with this tag; nullptr for one lbpkit does not know.
constexpr const ModuleKind* moduleKind(std::uint8_t t) {
  for (const ModuleKind* k : kModuleKinds)
    if (k->tag == t) return k;
  return nullptr;
}

// The module's name as the firmware and mesaflash spell it; empty if unknown.
constexpr std::string_view moduleName(std::uint8_t t) {
  if (t == tag::kIrq) return "IRQ";
  const ModuleKind* k = moduleKind(t);
  return k != nullptr ? k->name : std::string_view{};
}

}  // namespace lbpkit::wire::hm2
