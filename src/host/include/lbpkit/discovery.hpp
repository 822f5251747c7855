// SPDX-License-Identifier: MIT
// Process data discovery (manual: PROCESS DATA DISCOVERY): what a remote's
// PTOC and GTOC describe, read with as few remote reads as possible, and
// the engineering-unit scaling of numeric process data.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "lbpkit/wire/process_data.hpp"

namespace lbpkit {

// Byte-level access to a remote's memory and LBP locals, one LBP command per
// call (through SSLBP setup mode, or straight over a serial line).
class RemoteAccess {
 public:
  virtual ~RemoteAccess() = default;
  // size: 1, 2, 4 or 8 bytes, LSB first.
  virtual std::uint64_t read(std::uint16_t address, unsigned size) = 0;
  virtual void write(std::uint16_t address, unsigned size, std::uint64_t value) = 0;
  virtual std::uint8_t localRead(std::uint8_t command) = 0;
  virtual void localWrite(std::uint8_t command, std::uint8_t value) = 0;
  // LBP commands sent so far (each a DOIT through SSLBP).
  [[nodiscard]] virtual std::uint64_t transactions() const = 0;
  [[nodiscard]] virtual std::string where() const = 0;  // "channel 0", "/dev/ttyUSB0"
};

// DATA_TYPE and DATA_DIRECTION, as the protocol layer defines them.
using DataType = wire::lbp::DataType;
using Direction = wire::lbp::Direction;
using wire::lbp::isNonVolatile;

std::string typeName(DataType t);
std::string directionName(Direction d);

struct ProcessDataElement {
  std::string name;  // as the remote reports it ("Output", "AnalogOut0")
  std::string unit;
  DataType type = DataType::Pad;
  Direction direction = Direction::Input;
  unsigned bits = 0;
  float min = 0;
  float max = 0;
  std::uint16_t address = 0;  // PARAM_ADD
  std::uint16_t record = 0;   // where its descriptor is

  [[nodiscard]] bool fromRemote() const { return direction != Direction::Output; }
  [[nodiscard]] bool toRemote() const { return direction != Direction::Input; }
  [[nodiscard]] bool numeric() const;
  // The raw value: DATA_SIZE bits (the host keeps at most 64), two's
  // complement when the DATA_TYPE is signed (Signed, NonVolSigned).
  [[nodiscard]] unsigned width() const { return bits < 64 ? bits : 64; }
  [[nodiscard]] std::uint64_t rawMask() const { return width() >= 64 ? ~0ULL : (1ULL << width()) - 1; }
  [[nodiscard]] bool isSigned() const { return wire::lbp::isSigned(type); }
  // The integers the raw value holds: -2^(N-1) .. 2^(N-1)-1 signed,
  // 0 .. 2^N-1 unsigned; fits() is the range check.
  [[nodiscard]] std::int64_t lowest() const;
  [[nodiscard]] std::uint64_t highest() const { return isSigned() ? rawMask() >> 1 : rawMask(); }
  [[nodiscard]] bool fits(std::int64_t v) const;
  // An integer in range as the raw bits, and a raw value as an integer
  // (sign-extended when the type is signed).
  [[nodiscard]] std::uint64_t toRaw(std::int64_t v) const { return static_cast<std::uint64_t>(v) & rawMask(); }
  [[nodiscard]] std::int64_t fromRaw(std::uint64_t raw) const {
    return isSigned() ? wire::lbp::signExtend(raw, width()) : static_cast<std::int64_t>(raw);
  }
  // NUMERIC PROCESS DATA SCALING. Unsigned: min at 0, max at 2^N-1. Signed:
  // 0 at 0 and max at 2^(N-1)-1 (what LinuxCNC does; the manual's formula
  // is garbled). Other types: the raw value.
  [[nodiscard]] double scale(std::uint64_t raw) const;
  [[nodiscard]] std::uint64_t unscale(double value) const;  // clamped to min..max
};

struct ModeDescriptor {
  std::uint8_t index = 0;
  std::uint8_t type = 0;  // 0 hardware, 1 software
  std::string name;
};

struct RemoteDescription {
  std::vector<ProcessDataElement> processData;  // PTOC order
  std::vector<ProcessDataElement> parameters;   // GTOC entries not in the PTOC
  std::vector<ModeDescriptor> modes;            // the PTOC's: the current hardware and software modes
  // The GTOC's mode records: every mode the remote has (mesaflash walks each
  // software mode it finds there), and how many entries the GTOC holds.
  std::vector<ModeDescriptor> gtocModes;
  unsigned gtocEntries = 0;
  unsigned inputBits = 0;
  unsigned outputBits = 0;

  [[nodiscard]] unsigned rxBytes() const { return 1 + (inputBits + 7) / 8; }  // with the fault byte
  [[nodiscard]] unsigned txBytes() const { return (outputBits + 7) / 8; }
  // The remote reads discovering this would take at one byte per read (as
  // LinuxCNC's driver does: one DOIT per byte): both tables with their
  // sentinels, every record and its strings.
  [[nodiscard]] unsigned bytewiseReads() const;
  // Case-insensitive lookup in parameters then process data; also accepts
  // the manual's spellings (WATCHDOGTIME, NVWATCHDOGTIME, OUTPUT, FAULT...).
  [[nodiscard]] const ProcessDataElement* find(const std::string& name) const;
};

struct DiscoveryLimits {
  unsigned maxEntries = 64;     // per table
  unsigned maxString = 48;      // characters, as LinuxCNC's driver
  unsigned maxBitsPerDirection = 96;  // three interface registers
};

// Reads the PTOC and GTOC and every record they point to. Reads are 8 bytes
// wide where they fit and are cached, so a 7I77 takes about a sixth of the
// commands byte-wise reading needs. Throws lbpkit::Error naming the table,
// entry and address on any inconsistency. `expectedRx`/`expectedTx` (from
// the discovery RPC, when known) are checked against the PTOC's sizes.
RemoteDescription discover(RemoteAccess& remote, std::uint16_t ptoc, std::uint16_t gtoc,
                           std::optional<unsigned> expectedRx = std::nullopt,
                           std::optional<unsigned> expectedTx = std::nullopt, DiscoveryLimits limits = {});

// Manual spellings for the names real remotes report.
std::string canonicalParameterName(const std::string& name);

}  // namespace lbpkit
