// SPDX-License-Identifier: MIT
// Process data discovery records, data types and bit packing (manual:
// PROCESS DATA DISCOVERY; docs/protocol-facts.md#process-data-discovery).
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

namespace lbpkit::wire::lbp {

// DATA_TYPE (manual: DATA_TYPE; 0x08, 0x10, 0x11 as LinuxCNC's sserial driver knows them).
enum class DataType : std::uint8_t {
  Pad = 0x00,
  Bits = 0x01,
  Unsigned = 0x02,
  Signed = 0x03,
  NonVolUnsigned = 0x04,
  NonVolSigned = 0x05,
  Stream = 0x06,
  Boolean = 0x07,
  Encoder = 0x08,
  Float = 0x10,
  NonVolFloat = 0x11,
};

// DATA_DIRECTION.
enum class Direction : std::uint8_t {
  Input = 0x00,          // read from the remote
  Bidirectional = 0x40,  // read and written
  Output = 0x80,         // written to the remote
};

inline constexpr std::uint8_t kProcessDataRecord = 0xA0;  // RECORD_TYPE of a PDD
inline constexpr std::uint8_t kModeRecord = 0xB0;         // RECORD_TYPE of a mode descriptor
inline constexpr std::uint8_t kHwMode = 0x00;             // MODE TYPES
inline constexpr std::uint8_t kSwMode = 0x01;

// Byte layout of a PROCESS DATA DESCRIPTOR record: RECORD_TYPE, DATA_SIZE,
// DATA_TYPE, DATA_DIRECTION, PARAM_MIN (float), PARAM_MAX (float),
// PARAM_ADD (16 bits), then UNIT_STRING and NAME_STRING, each NUL-terminated.
namespace pdd {
inline constexpr unsigned kRecordType = 0;
inline constexpr unsigned kDataSize = 1;
inline constexpr unsigned kDataType = 2;
inline constexpr unsigned kDirection = 3;
inline constexpr unsigned kMin = 4;
inline constexpr unsigned kMax = 8;
inline constexpr unsigned kAddress = 12;
inline constexpr unsigned kStrings = 14;
}  // namespace pdd
// A MODE DESCRIPTOR record: RECORD_TYPE, MODE_INDEX, MODE_TYPE, unused, NAME_STRING.
namespace mode_record {
inline constexpr unsigned kRecordType = 0;
inline constexpr unsigned kIndex = 1;
inline constexpr unsigned kType = 2;
inline constexpr unsigned kName = 4;
}  // namespace mode_record

constexpr bool isKnownDataType(std::uint8_t t) { return t <= 0x08 || t == 0x10 || t == 0x11; }
constexpr bool isDirection(std::uint8_t d) { return d == 0x00 || d == 0x40 || d == 0x80; }

constexpr bool isNonVolatile(DataType t) {
  return t == DataType::NonVolUnsigned || t == DataType::NonVolSigned || t == DataType::NonVolFloat;
}
constexpr bool isSigned(DataType t) { return t == DataType::Signed || t == DataType::NonVolSigned; }

// One process data element or parameter: a PROCESS DATA DESCRIPTOR and the
// variable it describes. Devices declare theirs once, in one table.
struct ProcessDataDescriptor {
  std::string_view name;  // NAME_STRING
  std::string_view unit;  // UNIT_STRING
  DataType type;
  Direction direction;
  std::uint8_t bits;  // DATA_SIZE
  float min;          // PARAM_MIN
  float max;          // PARAM_MAX
};

constexpr unsigned byteSize(const ProcessDataDescriptor& d) { return (d.bits + 7U) / 8U; }

// Bit-level packing of process data in PTOC order, LSB first, across
// consecutive bytes (manual: PROCESS ELEMENT PACKING AND UNPACKING). Bits
// beyond the buffer are dropped on packing and read as 0 on unpacking.
void packBits(std::span<std::uint8_t> buffer, unsigned bitOffset, unsigned bits, std::uint64_t value);
std::uint64_t unpackBits(std::span<const std::uint8_t> buffer, unsigned bitOffset, unsigned bits);
// Both move an element as one 64-bit word when the eight bytes from its
// first fit the buffer, and byte by byte otherwise: a buffer with this many
// bytes past its data (zero, to read as nothing) makes every element one word.
inline constexpr std::size_t kPackingRoom = 8;
// Two's complement sign extension of a `bits`-wide raw value.
constexpr std::int64_t signExtend(std::uint64_t raw, unsigned bits) {
  if (bits == 0 || bits >= 64) return static_cast<std::int64_t>(raw);
  const std::uint64_t sign = 1ULL << (bits - 1);
  raw &= (sign << 1) - 1;
  return static_cast<std::int64_t>(raw ^ sign) - static_cast<std::int64_t>(sign);
}

}  // namespace lbpkit::wire::lbp
