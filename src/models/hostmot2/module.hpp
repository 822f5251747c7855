// SPDX-License-Identifier: MIT
// A HostMot2 module: a block of 32-bit registers in the card's address space
// plus the IDROM module descriptor that tells drivers where it is
// (HostMot2 regmap; docs/protocol-facts.md#module-tags). One module per file, like LinuxCNC's
// hostmot2 driver.
#pragma once

#include <cstdint>
#include <string_view>

#include "lbp/sim_time.hpp"
#include "lbpkit/wire/hostmot2.hpp"

namespace lbpkit::model::hm2 {

using lbp::SimTime;

// The module map (tags, clocks, strides, every kind's registers) is the
// wire library's: models answer at the addresses it gives.
namespace map = lbpkit::wire::hm2;
namespace tag = lbpkit::wire::hm2::tag;
using lbpkit::wire::hm2::kClockHigh;
using lbpkit::wire::hm2::kClockLow;
using lbpkit::wire::hm2::kInstanceStride0;
using lbpkit::wire::hm2::kInstanceStride1;
using lbpkit::wire::hm2::kRegisterStride;
using lbpkit::wire::hm2::ModuleKind;

// One IDROM module record (idrom.vhd): three 32-bit words.
struct ModuleDescriptor {
  std::uint8_t gtag = 0;
  std::uint8_t version = 0;
  std::uint8_t clockTag = kClockLow;
  std::uint8_t instances = 0;
  std::uint16_t baseAddress = 0;
  std::uint8_t registers = 0;
  std::uint8_t strides = 0;  // low nibble: register stride select, high: instance stride select
  std::uint32_t multipleRegisters = 0;
};

// What became of a register write, so the card can count the writes a
// module refuses (HostMot2Card::accessCounters()). Returned by value on the
// per-access path: no allocation, no logging in the model.
enum class WriteResult : std::uint8_t {
  Accepted,
  Unmapped,        // the module's block, but no register there (e.g. a channel it does not have)
  ReadOnly,        // a register that cannot be written: the value is dropped
  IgnoredCommand,  // SSLBP COMMAND with bit 31 set (docs/protocol-facts.md#sslbp-command-register)
  LostCommand,     // SSLBP command written while one runs: lost, DATA then reads 0xFF
};

// A module of one kind of the map, at `base`, with `instances` (what its
// IDROM record says). The base answers what the map decides: its name and
// descriptor, which addresses it decodes, and (through the card) that
// read-only registers drop writes and write-only ones read 0. A model's
// read and write keep only the behaviour of its registers.
class Module {
 public:
  Module(const ModuleKind& kind, std::uint16_t base, unsigned instances, std::uint8_t version)
      : kind_(&kind), base_(base), instances_(instances), version_(version) {}
  virtual ~Module() = default;
  Module(const Module&) = delete;
  Module& operator=(const Module&) = delete;

  [[nodiscard]] const ModuleKind& kind() const { return *kind_; }
  [[nodiscard]] std::string_view name() const { return kind_->name; }
  [[nodiscard]] ModuleDescriptor descriptor() const {
    return ModuleDescriptor{kind_->tag,     version_,         kind_->clock,
                            static_cast<std::uint8_t>(instances_), base_, kind_->idromRegisters,
                            kind_->strides, kind_->multipleRegisters()};
  }
  [[nodiscard]] std::uint16_t base() const { return base_; }
  [[nodiscard]] unsigned instances() const { return instances_; }
  // The map's register whose block holds `address`; nullptr for none.
  [[nodiscard]] const map::Register* registerAt(std::uint16_t address) const {
    if (address < base_) return nullptr;
    return kind_->at(static_cast<unsigned>(address - base_) / kRegisterStride);
  }
  [[nodiscard]] map::Access accessAt(std::uint16_t address) const {
    const map::Register* r = registerAt(address);
    return r != nullptr ? r->access : map::Access::ReadWrite;
  }
  // Does this module answer at `address`? As the map has it: a single
  // register at its block's first word, one per instance (or channel) 4
  // bytes apart. A model whose decoding differs says so where it overrides.
  [[nodiscard]] virtual bool decodes(std::uint16_t address) const {
    const map::Register* r = registerAt(address);
    if (r == nullptr || r->presence != map::Presence::Always) return false;
    const unsigned offset = static_cast<unsigned>(address - base_) % kRegisterStride;
    return r->scope == map::Scope::Single ? offset == 0 : offset < instances_ * 4U;
  }
  // An access at `address` (a register's: a multiple of 4). The map
  // answers where nothing is there (a read gives 0, a write is Unmapped), a
  // write to a read-only register (dropped: ReadOnly) and a read of a
  // write-only one (0); the model's registers answer the rest.
  std::uint32_t read(std::uint16_t address, SimTime now) {
    if (!decodes(address) || accessAt(address) == map::Access::WriteOnly) return 0;
    return readRegister(address, now);
  }
  WriteResult write(std::uint16_t address, std::uint32_t value, SimTime now) {
    if (!decodes(address)) return WriteResult::Unmapped;
    if (accessAt(address) == map::Access::ReadOnly) return WriteResult::ReadOnly;
    return writeRegister(address, value, now);
  }
  // Let simulated time pass.
  virtual void advance(SimTime now) { (void)now; }
  // Back to the state the module powers up in, as a freshly configured FPGA
  // has it (HostMot2 regmap: every register at its power-up value). What the
  // world drives into the card (encoder signals, GPIO input levels) and the
  // cables behind it are not the module's and stay; simulated time does not
  // go back. The card's powerCycle() calls this for every module.
  virtual void reset() = 0;

 protected:
  // The card's per-access path calls these itself, having decided what the
  // map answers once per register block when it was built.
  friend class HostMot2Card;
  // What the model does for an access the map lets through.
  virtual std::uint32_t readRegister(std::uint16_t address, SimTime now) = 0;
  virtual WriteResult writeRegister(std::uint16_t address, std::uint32_t value, SimTime now) = 0;

  // Register `index` of the map, as an index a model's switch can take.
  [[nodiscard]] unsigned block(std::uint16_t address) const {
    return static_cast<unsigned>(address - base_) / kRegisterStride;
  }
  // The instance (or channel) a per-instance register's address names.
  [[nodiscard]] static unsigned instanceOf(std::uint16_t address) { return (address % kRegisterStride) / 4U; }

  const ModuleKind* kind_;
  std::uint16_t base_;
  unsigned instances_;
  std::uint8_t version_;
};

// Whole clock cycles in a (non-negative) span of simulated time, without
// overflow: nanoseconds times 100 MHz would pass 2^64 after 184 s.
constexpr std::uint64_t clockTicks(SimTime t, std::uint32_t hz) {
  const auto ns = static_cast<std::uint64_t>(t.count() < 0 ? 0 : t.count());
  return ns / 1'000'000'000U * hz + ns % 1'000'000'000U * hz / 1'000'000'000U;
}

}  // namespace lbpkit::model::hm2
