// SPDX-License-Identifier: MIT
#include "lbpkit/wire/process_data.hpp"

#include <bit>
#include <cstring>

namespace lbpkit::wire::lbp {

// Both run for every element of every process data exchange, host and
// remote side, so they move whole bytes: the bytes an element touches
// (at most 8 unless it is over 56 bits at an odd offset) are gathered into
// one 64-bit word, least significant first, and scattered back. Bytes past
// the buffer's end are not touched and read as 0, as the bit-wise rule says.

namespace {
constexpr std::uint64_t lowBits(unsigned bits) {
  return bits >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << bits) - 1;
}

// The element's bytes are all in the buffer and it is little-endian: one load.
bool wholeWord(std::size_t size, std::size_t first) {
  return std::endian::native == std::endian::little && first + 8 <= size;
}

std::uint64_t gather(const std::uint8_t* buffer, std::size_t size, std::size_t first, unsigned bytes) {
  std::uint64_t word = 0;
  if (wholeWord(size, first)) {
    std::memcpy(&word, buffer + first, sizeof word);
    return word;
  }
  for (unsigned k = 0; k < bytes && first + k < size; ++k)
    word |= static_cast<std::uint64_t>(buffer[first + k]) << (8 * k);
  return word;
}
}  // namespace

void packBits(std::span<std::uint8_t> buffer, unsigned bitOffset, unsigned bits, std::uint64_t value) {
  if (bits > 64) bits = 64;
  const unsigned shift = bitOffset % 8;
  const std::size_t first = bitOffset / 8;
  const unsigned bytes = (shift + bits + 7) / 8;
  if (bytes <= 8) {
    const std::uint64_t mask = lowBits(bits) << shift;
    std::uint64_t word = gather(buffer.data(), buffer.size(), first, bytes);
    word = (word & ~mask) | ((value << shift) & mask);
    if (wholeWord(buffer.size(), first)) {
      std::memcpy(buffer.data() + first, &word, sizeof word);
      return;
    }
    for (unsigned k = 0; k < bytes && first + k < buffer.size(); ++k)
      buffer[first + k] = static_cast<std::uint8_t>(word >> (8 * k));
    return;
  }
  // Over 56 bits at an odd offset: byte by byte, each step moving the bits
  // that fall into one buffer byte.
  for (unsigned i = 0; i < bits;) {
    const unsigned bit = bitOffset + i;
    if (bit / 8 >= buffer.size()) return;
    const unsigned s = bit % 8;
    const unsigned n = bits - i < 8 - s ? bits - i : 8 - s;
    const unsigned m = ((1U << n) - 1U) << s;
    const unsigned v = (static_cast<unsigned>(value >> i) << s) & m;
    buffer[bit / 8] = static_cast<std::uint8_t>((buffer[bit / 8] & ~m) | v);
    i += n;
  }
}

std::uint64_t unpackBits(std::span<const std::uint8_t> buffer, unsigned bitOffset, unsigned bits) {
  if (bits > 64) bits = 64;
  const unsigned shift = bitOffset % 8;
  const std::size_t first = bitOffset / 8;
  const unsigned bytes = (shift + bits + 7) / 8;
  if (bytes <= 8) return (gather(buffer.data(), buffer.size(), first, bytes) >> shift) & lowBits(bits);
  std::uint64_t value = 0;
  for (unsigned i = 0; i < bits;) {
    const unsigned bit = bitOffset + i;
    if (bit / 8 >= buffer.size()) break;
    const unsigned s = bit % 8;
    const unsigned n = bits - i < 8 - s ? bits - i : 8 - s;
    const unsigned v = (static_cast<unsigned>(buffer[bit / 8]) >> s) & ((1U << n) - 1U);
    value |= static_cast<std::uint64_t>(v) << i;
    i += n;
  }
  return value;
}

}  // namespace lbpkit::wire::lbp
