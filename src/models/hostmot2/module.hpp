// A HostMot2 module: a block of 32-bit registers in the card's address space
// plus the IDROM module descriptor that tells drivers where it is
// (HostMot2 regmap; docs/protocol-facts.md#module-tags). One module per file, like LinuxCNC's
// hostmot2 driver.
#pragma once

#include <cstdint>
#include <string_view>

#include "lbp/sim_time.hpp"
#include "lbpkit/wire/hostmot2.hpp"

namespace hm2 {

using lbp::SimTime;
using namespace std::chrono_literals;

// Module tags, clock tags and strides are wire facts the driver shares.
namespace tag = lbpkit::wire::hm2::tag;
using lbpkit::wire::hm2::kClockHigh;
using lbpkit::wire::hm2::kClockLow;
using lbpkit::wire::hm2::kInstanceStride0;
using lbpkit::wire::hm2::kInstanceStride1;
using lbpkit::wire::hm2::kRegisterStride;

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

class Module {
 public:
  virtual ~Module() = default;
  [[nodiscard]] virtual std::string_view name() const = 0;
  [[nodiscard]] virtual ModuleDescriptor descriptor() const = 0;
  // Does this module answer at `address`?
  [[nodiscard]] virtual bool decodes(std::uint16_t address) const = 0;
  virtual std::uint32_t read(std::uint16_t address, SimTime now) = 0;
  virtual WriteResult write(std::uint16_t address, std::uint32_t value, SimTime now) = 0;
  // Let simulated time pass.
  virtual void advance(SimTime now) { (void)now; }
  // Back to the state the module powers up in, as a freshly configured FPGA
  // has it (HostMot2 regmap: every register at its power-up value). What the
  // world drives into the card (encoder signals, GPIO input levels) and the
  // cables behind it are not the module's and stay; simulated time does not
  // go back. The card's powerCycle() calls this for every module.
  virtual void reset() = 0;
};

// Whole clock cycles in a (non-negative) span of simulated time, without
// overflow: nanoseconds times 100 MHz would pass 2^64 after 184 s.
constexpr std::uint64_t clockTicks(SimTime t, std::uint32_t hz) {
  const auto ns = static_cast<std::uint64_t>(t.count() < 0 ? 0 : t.count());
  return ns / 1'000'000'000U * hz + ns % 1'000'000'000U * hz / 1'000'000'000U;
}

}  // namespace hm2
