// SPDX-License-Identifier: MIT
// libFuzzer target: arbitrary datagrams into the virtual card's LBP16
// handler. Nothing may crash, hang or read out of bounds, and the card must
// still answer a well-formed request afterwards.
#include <cstdint>
#include <cstdlib>
#include <span>

#include "hostmot2/card.hpp"
#include "lbp16/lbp16_card.hpp"

// The layers' namespaces this file names (docs/architecture.md).
namespace hm2 = lbpkit::model::hm2;
namespace server = lbpkit::server;

namespace {
struct World {
  hm2::HostMot2Card card;
  server::Lbp16Card lbp16{card, server::Lbp16Card::Identity{}};
  hm2::SimTime now{0};
};
World& world() {
  static World w;
  return w;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  auto& w = world();
  std::uint8_t reply[server::Lbp16Card::kMaxDatagram];
  w.now += hm2::SimTime{50'000};
  const std::size_t n = w.lbp16.handle(std::span<const std::uint8_t>(data, size), reply, w.now);
  if (n > sizeof reply) std::abort();
  // The cookie is still there.
  const std::uint8_t cookieRead[4] = {0x01, 0x42, 0x00, 0x01};  // read HM2 1x32 at 0x0100
  if (w.lbp16.handle(cookieRead, reply, w.now) != 4) std::abort();
  const std::uint32_t cookie = std::uint32_t{reply[0]} | (std::uint32_t{reply[1]} << 8) |
                               (std::uint32_t{reply[2]} << 16) | (std::uint32_t{reply[3]} << 24);
  if (cookie != 0x55AACAFEU) std::abort();
  return 0;
}
