#include "lbpkit/wire/process_data.hpp"

namespace lbpkit::wire::lbp {

void packBits(std::span<std::uint8_t> buffer, unsigned bitOffset, unsigned bits, std::uint64_t value) {
  for (unsigned i = 0; i < bits && i < 64; ++i) {
    const unsigned bit = bitOffset + i;
    if (bit / 8 >= buffer.size()) return;
    const auto mask = static_cast<std::uint8_t>(1U << (bit % 8));
    if ((value >> i) & 1U)
      buffer[bit / 8] = static_cast<std::uint8_t>(buffer[bit / 8] | mask);
    else
      buffer[bit / 8] = static_cast<std::uint8_t>(buffer[bit / 8] & ~mask);
  }
}

std::uint64_t unpackBits(std::span<const std::uint8_t> buffer, unsigned bitOffset, unsigned bits) {
  std::uint64_t value = 0;
  for (unsigned i = 0; i < bits && i < 64; ++i) {
    const unsigned bit = bitOffset + i;
    if (bit / 8 >= buffer.size()) break;
    if ((static_cast<unsigned>(buffer[bit / 8]) >> (bit % 8)) & 1U) value |= 1ULL << i;
  }
  return value;
}

}  // namespace lbpkit::wire::lbp
