// SPDX-License-Identifier: MIT
// libFuzzer target: arbitrary byte streams (with arbitrary gaps) into a 7I77
// field I/O processor's LBP parser.
#include <cstdint>
#include <cstdlib>

#include "lbp/protocol.hpp"
#include "remote/field_io.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace remote = lbpkit::model::remote;
namespace lbp = lbpkit::model::lbp;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  remote::FieldIoProcessor io;
  lbp::SimTime now{0};
  for (std::size_t i = 0; i + 1 < size; i += 2) {
    // Even bytes are data, odd bytes pick the gap before them.
    now += lbp::characterTime(io.baud()) * (1 + (data[i + 1] & 0x3F));
    const auto reply = io.receive(data[i], now);
    if (reply.size() > lbp::Parser::kMaxResponse) std::abort();
  }
  // After a gap the parser answers the cookie read.
  now += std::chrono::milliseconds(10);
  const std::uint8_t c = 0xDF;
  (void)io.receive(c, now);
  now += lbp::characterTime(io.baud());
  const auto reply = io.receive(lbp::crc8(std::span<const std::uint8_t>(&c, 1)), now);
  if (!io.powered()) return 0;  // a fuzzed reset/power cut: fine
  if (reply.size() != 2 || reply[0] != 0x5A) std::abort();
  return 0;
}
