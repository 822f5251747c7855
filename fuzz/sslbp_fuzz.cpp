// SPDX-License-Identifier: MIT
// libFuzzer target: random register reads and writes from the host side to
// the HostMot2 card's SSLBP (COMMAND, DATA, CS, interface registers of every
// channel), with random time between them, against the 7I77's processors.
// Whatever the host did, the card never crashes, and STOP ALL always
// brings COMMAND back to 0 (the manual: SSLBP COMMAND REGISTER; lbpkit's
// choice: STOP always works).
#include <chrono>
#include <cstdint>
#include <cstdlib>

#include "hostmot2/card.hpp"
#include "hostmot2/sslbp.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace std::chrono_literals;
  hm2::HostMot2Card card;
  hm2::SimTime now{0};
  // Each step: 1 byte op (bit 7 write, bits 6..5 register, bits 4..2 channel,
  // bits 1..0 interface), 1 byte gap (x 1 us), 4 bytes value.
  for (std::size_t i = 0; i + 6 <= size; i += 6) {
    const std::uint8_t op = data[i];
    now += std::chrono::microseconds(data[i + 1]);
    const std::uint32_t value = static_cast<std::uint32_t>(data[i + 2]) | static_cast<std::uint32_t>(data[i + 3]) << 8 |
                                static_cast<std::uint32_t>(data[i + 4]) << 16 |
                                static_cast<std::uint32_t>(data[i + 5]) << 24;
    const unsigned reg = (op >> 5) & 3U, ch = (op >> 2) & 7U, n = op & 3U;
    std::uint16_t address = hm2::Sslbp::kCommand;
    if (reg == 1) address = hm2::Sslbp::kData;
    if (reg == 2) address = static_cast<std::uint16_t>(hm2::Sslbp::kCs + 4 * ch);
    if (reg == 3) address = static_cast<std::uint16_t>(hm2::Sslbp::kInterface0 + 0x100 * (n % 3) + 4 * ch);
    if (op & 0x80)
      card.write32(address, value, now);
    else
      (void)card.read32(address, now);
  }
  // STOP ALL (twice: the first may only release the M bit, whose boot drops
  // the command that releases it) ends whatever was running.
  for (int k = 0; k < 2; ++k) {
    now += 1ms;
    card.write32(hm2::Sslbp::kCommand, hm2::command::kStop, now);
  }
  now += 10ms;
  if (card.read32(hm2::Sslbp::kCommand, now) != 0) std::abort();
  return 0;
}
